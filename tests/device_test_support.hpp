// Helpers for tests that count the OpenCL buffers the library holds.
#pragma once

#include <chrono>
#include <cstdint>
#include <thread>

#include "buffer_pool.hpp"
#include "opencl_runtime.hpp"

namespace trilevel::test {

/// Live device buffers once PoCL has released those used by finished commands (it frees them on
/// its own threads, shortly after the last command is done) and `expected` is reached, or after a second.
inline std::int64_t settled_live_buffers(std::int64_t expected) {
    for (int i = 0; i < 200 && live_device_buffers() != expected; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return live_device_buffers();
}

/// Between frames every live buffer belongs to a buffer pool: what this returns are leaks.
inline std::int64_t settled_unpooled_buffers() {
    settled_live_buffers(pooled_device_buffers());
    return live_device_buffers() - pooled_device_buffers();
}

}  // namespace trilevel::test
