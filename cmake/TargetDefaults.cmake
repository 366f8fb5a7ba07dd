# Settings every trilevel target shares, stated once.
#   trilevel_warnings(target): the warnings of the project's own code (-Wall -Wextra; OpenCL's
#     headers put attributes on template arguments, which GCC reports as ignored).
#   trilevel_opencl_cpp(target): the OpenCL C++ bindings as the library and its tests use them
#     (OpenCL 3.0 headers, 2.0 at least, errors as cl::Error exceptions).
function(trilevel_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-ignored-attributes)
endfunction()
function(trilevel_opencl_cpp target)
  target_compile_definitions(${target} PRIVATE CL_HPP_TARGET_OPENCL_VERSION=300 CL_HPP_MINIMUM_OPENCL_VERSION=200
    CL_HPP_ENABLE_EXCEPTIONS)
endfunction()
