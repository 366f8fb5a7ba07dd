// Positions in a caller's OpenCL buffer (Reconstructor::reconstruct on DevicePositions): their
// bounds and the binning input computed on the device, or a copy on the host where the device
// path cannot give the host path's bits.
#pragma once

#include <cstddef>
#include <vector>

#include <glm/glm.hpp>

#include "device_stages.hpp"
#include "domain_split.hpp"
#include "opencl_runtime.hpp"

namespace trilevel {

/// Particle i's x, y, z: the floats at byte offset + i * stride of `buffer` (both multiples of 4).
struct DeviceInput {
    cl::Buffer buffer;
    std::size_t count = 0, offset = 0, stride = 12;
};

/// Checks the layout against the buffer (its size and context): one-line Error otherwise.
DeviceInput device_input(OpenCLRuntime& rt, _cl_mem* buffer, std::size_t count, std::size_t offset, std::size_t stride);

/// The bounds bounds_of would compute on the host, and its Error for the first particle with a
/// non-finite coordinate. One pass over the particles; the host reads 8 floats per work-item.
Bounds device_bounds(OpenCLRuntime& rt, const DeviceInput& in);

/// Stage 1 on the caller's positions: gathered on the device into the binning input, relative to
/// `origin` (rounded as the host upload rounds: needs OpenCLRuntime::has_fp64).
BinnedParticles bin_device_positions(OpenCLRuntime& rt, const DeviceInput& in, glm::dvec3 origin, float cell,
                                     const PairLoadCheck& check_load = {});

/// Particles 0, step, 2 step, ... copied to the host, x, y, z each (one rectangular read).
std::vector<float> read_device_sample(OpenCLRuntime& rt, const DeviceInput& in, std::size_t step);

/// The positions copied to the host, x, y, z per particle (the fallback of the device path).
std::vector<float> read_device_positions(OpenCLRuntime& rt, const DeviceInput& in);

}  // namespace trilevel
