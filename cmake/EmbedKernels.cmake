# trilevel_embed_kernels(OUT FUNCTION DIR file...) generates OUT, a C++ file that defines
# std::string trilevel::FUNCTION(): the files DIR/file..., joined in the given order (the ordered
# lists of kernels/kernels.cmake).
set(TRILEVEL_EMBED_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/EmbedKernelsScript.cmake)
function(trilevel_embed_kernels out function dir)
  set(abs_sources)
  foreach(src ${ARGN})
    list(APPEND abs_sources ${dir}/${src})
  endforeach()
  string(REPLACE ";" "|" joined "${abs_sources}")
  add_custom_command(OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -DOUT=${out} -DFUNCTION=${function} "-DSOURCES=${joined}" -P ${TRILEVEL_EMBED_SCRIPT}
    DEPENDS ${abs_sources} ${TRILEVEL_EMBED_SCRIPT}
    COMMENT "Embedding OpenCL kernels" VERBATIM)
endfunction()
