// See test_kernels.hpp.
#include "support/test_kernels.hpp"

#include <map>
#include <string>
#include <utility>

#include "trilevel/trilevel.hpp"

namespace trilevel {
std::string embedded_test_program_source();  // generated at build time (tests/CMakeLists.txt)
}

namespace trilevel::test {

cl::Kernel test_kernel(OpenCLRuntime& rt, const char* name) {
    // One program per context: the tests keep one runtime, but nothing here assumes it.
    static std::map<cl_context, cl::Program> programs;
    auto it = programs.find(rt.context()());
    if (it == programs.end()) {
        const cl::Device device = rt.queue().getInfo<CL_QUEUE_DEVICE>();
        cl::Program program(rt.context(), embedded_test_program_source());
        try {
            program.build(std::vector<cl::Device>{device}, "-cl-std=CL1.2 -DFINE_KEY_BITS=64");
        } catch (const cl::Error&) {
            throw Error("test kernel build failed: " + program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device));
        }
        it = programs.emplace(rt.context()(), std::move(program)).first;
    }
    return cl::Kernel(it->second, name);
}

void hash_insert_keys(OpenCLRuntime& rt, const cl::Buffer& in, std::size_t n, const cl::Buffer& keys,
                      std::size_t capacity, const cl::Buffer& slot_of, const cl::Buffer& stats) {
    if (n == 0) return;
    cl::Kernel k = test_kernel(rt, "hash_insert_keys");
    k.setArg(0, in);
    k.setArg(1, cl_uint(n));
    k.setArg(2, keys);
    k.setArg(3, cl_ulong(capacity));
    k.setArg(4, slot_of);
    k.setArg(5, stats);
    rt.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(n), cl::NullRange);
    rt.queue().finish();
}

}  // namespace trilevel::test
