# ctest -R cmake_add_subdirectory: configures tests/embed_test (a simulator project that
# add_subdirectory()s the trilevel source tree), builds examples/simulator_loop in it and runs it.
# Arguments (-D): SOURCE_DIR, WORK_DIR, GENERATOR, CXX_COMPILER, BUILD_TYPE, LAUNCHER (optional).
include(${CMAKE_CURRENT_LIST_DIR}/cmake_run.cmake)  # run()

file(REMOVE_RECURSE ${WORK_DIR})
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/embed_test -B ${WORK_DIR} -G ${GENERATOR}
    -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_BUILD_TYPE=${BUILD_TYPE} -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER}
    -DTRILEVEL_SOURCE_DIR=${SOURCE_DIR})
# trilevel's own tests stay off inside another project.
file(STRINGS ${WORK_DIR}/CMakeCache.txt tests_flag REGEX "^TRILEVEL_BUILD_TESTS:")
if(NOT tests_flag MATCHES "=OFF$")
  message(FATAL_ERROR "trilevel's tests are on inside another project: ${tests_flag}")
endif()
run(${CMAKE_COMMAND} --build ${WORK_DIR} --target simulator_loop --parallel 2)
run(${WORK_DIR}/simulator_loop)
message("${out}")
file(REMOVE_RECURSE ${WORK_DIR})
