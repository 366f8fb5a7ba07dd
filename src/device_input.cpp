#include "device_input.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

namespace trilevel {

DeviceInput device_input(OpenCLRuntime& rt, _cl_mem* buffer, std::size_t count, std::size_t offset, std::size_t stride) {
    if (!buffer) throw Error("device positions: no buffer (null cl_mem)");
    if (stride < 12 || stride % 4 != 0)
        throw Error("device positions: stride of " + std::to_string(stride) +
                    " bytes; it must be a multiple of 4 and at least 12 (x, y, z floats)");
    if (offset % 4 != 0) throw Error("device positions: offset of " + std::to_string(offset) + " bytes is not a multiple of 4");
    DeviceInput in;
    in.buffer = cl::Buffer(buffer, true);  // retained for the call
    in.count = count;
    in.offset = offset;
    in.stride = stride;
    if (in.buffer.getInfo<CL_MEM_CONTEXT>()() != rt.context()())
        throw Error("device positions: the buffer belongs to another OpenCL context than the Reconstructor's");
    const std::size_t size = in.buffer.getInfo<CL_MEM_SIZE>();
    const double needed = double(offset) + double(count - 1) * double(stride) + 12.0;  // count > 0: checked before
    if (needed > double(size))
        throw Error("device positions: " + std::to_string(count) + " particles at offset " + std::to_string(offset) +
                    " and stride " + std::to_string(stride) + " need " + std::to_string(std::uint64_t(needed)) +
                    " bytes, but the buffer holds " + std::to_string(size));
    return in;
}

Bounds device_bounds(OpenCLRuntime& rt, const DeviceInput& in) {
    constexpr std::size_t kLocal = 64;
    // Enough work-items to fill the device, few enough that their partials are a small read.
    const std::size_t groups =
        std::clamp<std::size_t>((in.count + kLocal * 64 - 1) / (kLocal * 64), 1, std::max<std::size_t>(4, 4 * rt.info().compute_units));
    const std::size_t items = groups * kLocal;
    DeviceBuffer partial = rt.buffer(items * 8 * sizeof(cl_float), "position bounds");
    DeviceBuffer bad = rt.buffer(sizeof(cl_uint), "position bounds flag");
    const cl_uint n = cl_uint(in.count);
    rt.queue().enqueueFillBuffer(bad, n, 0, sizeof(cl_uint));
    cl::Kernel& k = rt.kernel("positions_bounds");
    k.setArg(0, in.buffer);
    k.setArg(1, cl_ulong(in.offset / 4));
    k.setArg(2, cl_ulong(in.stride / 4));
    k.setArg(3, n);
    k.setArg(4, static_cast<const cl::Buffer&>(partial));
    k.setArg(5, static_cast<const cl::Buffer&>(bad));
    rt.run_groups("positions_bounds", groups, kLocal);
    std::vector<float> p(items * 8);
    cl_uint first_bad = n;
    rt.queue().enqueueReadBuffer(partial, CL_FALSE, 0, p.size() * sizeof(float), p.data());
    rt.queue().enqueueReadBuffer(bad, CL_TRUE, 0, sizeof(cl_uint), &first_bad);
    if (first_bad < n) throw Error("particle " + std::to_string(first_bad) + " has a non-finite coordinate");
    Bounds b;
    for (int a = 0; a < 3; ++a) {
        b.lo[a] = INFINITY;
        b.hi[a] = -INFINITY;
    }
    for (std::size_t g = 0; g < items; ++g)
        for (int a = 0; a < 3; ++a) {
            b.lo[a] = std::min(b.lo[a], double(p[8 * g + a]));
            b.hi[a] = std::max(b.hi[a], double(p[8 * g + 3 + a]));
            b.max_abs = std::max(b.max_abs, double(p[8 * g + 6]));
        }
    return b;
}

BinnedParticles bin_device_positions(OpenCLRuntime& rt, const DeviceInput& in, glm::dvec3 origin, float cell,
                                     const PairLoadCheck& check_load) {
    if (!rt.has_fp64()) throw Error("internal: the device gather needs cl_khr_fp64");
    const cl_uint n = cl_uint(in.count);
    DeviceBuffer pos = rt.buffer(std::size_t(n) * sizeof(glm::vec3), "particle positions");  // as bin_particles
    cl::Kernel& k = rt.kernel("gather_positions");
    k.setArg(0, in.buffer);
    k.setArg(1, cl_ulong(in.offset / 4));
    k.setArg(2, cl_ulong(in.stride / 4));
    k.setArg(3, n);
    k.setArg(4, cl_double(origin.x));
    k.setArg(5, cl_double(origin.y));
    k.setArg(6, cl_double(origin.z));
    k.setArg(7, static_cast<const cl::Buffer&>(pos));
    rt.run("gather_positions", n);
    return bin_positions(rt, std::move(pos), in.count, cell, check_load);
}

std::vector<float> read_device_sample(OpenCLRuntime& rt, const DeviceInput& in, std::size_t step) {
    const std::size_t m = (in.count + step - 1) / step;
    std::vector<float> xyz(3 * m);
    if (m == 0) return xyz;
    const cl::array<cl::size_type, 3> at{in.offset, 0, 0}, host_at{0, 0, 0}, region{12, m, 1};
    rt.queue().enqueueReadBufferRect(in.buffer, CL_TRUE, at, host_at, region, step * in.stride, 0, 12, 0, xyz.data());
    return xyz;
}

std::vector<float> read_device_positions(OpenCLRuntime& rt, const DeviceInput& in) {
    std::vector<float> xyz(3 * in.count);
    if (in.stride == 12) {
        rt.queue().enqueueReadBuffer(in.buffer, CL_TRUE, in.offset, xyz.size() * sizeof(float), xyz.data());
        return xyz;
    }
    const std::size_t span = (in.count - 1) * in.stride + 12;  // count > 0: checked before
    std::vector<unsigned char> raw(span);
    rt.queue().enqueueReadBuffer(in.buffer, CL_TRUE, in.offset, span, raw.data());
    for (std::size_t i = 0; i < in.count; ++i) std::memcpy(&xyz[3 * i], &raw[i * in.stride], 12);
    return xyz;
}

}  // namespace trilevel
