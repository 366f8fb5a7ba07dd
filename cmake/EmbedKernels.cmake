# trilevel_embed_kernels(OUT file.cl...) generates OUT, a C++ file that defines
# trilevel::embedded_kernel_source(name) returning the text of kernels/<name>.cl.
function(trilevel_embed_kernels out)
  set(abs_sources)
  foreach(src ${ARGN})
    list(APPEND abs_sources ${CMAKE_SOURCE_DIR}/${src})
  endforeach()
  string(REPLACE ";" "|" joined "${abs_sources}")
  add_custom_command(OUTPUT ${out}
    COMMAND ${CMAKE_COMMAND} -DOUT=${out} "-DSOURCES=${joined}" -P ${CMAKE_SOURCE_DIR}/cmake/EmbedKernelsScript.cmake
    DEPENDS ${abs_sources} ${CMAKE_SOURCE_DIR}/cmake/EmbedKernelsScript.cmake
    COMMENT "Embedding OpenCL kernels" VERBATIM)
endfunction()
