# ctest -R cmake_package: installs the built project into a fresh prefix, checks that exactly the
# public headers were installed, then configures, builds and runs examples/simulator_loop out of
# tree against that prefix, as a simulator project would.
# Arguments (-D): SOURCE_DIR, BUILD_DIR, WORK_DIR, GENERATOR, CXX_COMPILER, BUILD_TYPE.
include(${CMAKE_CURRENT_LIST_DIR}/cmake_run.cmake)  # run()

set(prefix ${WORK_DIR}/prefix)
file(REMOVE_RECURSE ${WORK_DIR})
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix} --config ${BUILD_TYPE})

file(GLOB_RECURSE installed RELATIVE ${prefix}/include ${prefix}/include/*)
file(GLOB_RECURSE public RELATIVE ${SOURCE_DIR}/include ${SOURCE_DIR}/include/*.hpp)
list(SORT installed)
list(SORT public)
if(NOT installed STREQUAL public OR public STREQUAL "")
  message(FATAL_ERROR "installed headers '${installed}' differ from the public headers '${public}'")
endif()

run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/simulator_loop -B ${WORK_DIR}/example -G ${GENERATOR}
    -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_BUILD_TYPE=${BUILD_TYPE} -DCMAKE_PREFIX_PATH=${prefix})
# It must have found this installation, not another one on the system.
file(STRINGS ${WORK_DIR}/example/CMakeCache.txt found REGEX "^trilevel_DIR:")
if(NOT found MATCHES "${prefix}/")
  message(FATAL_ERROR "the example found another trilevel: ${found}")
endif()
run(${CMAKE_COMMAND} --build ${WORK_DIR}/example)
run(${WORK_DIR}/example/simulator_loop)
message("${out}")
file(REMOVE_RECURSE ${WORK_DIR})
