// The tests' own OpenCL program: kernels that only the tests launch (tests/kernels/*.cl), built
// after the library's contract.h and hash_table.cl so that they call the same device functions as
// the pipeline's kernels. Never part of the library's program (kernels/kernels.cmake).
#pragma once

#include <cstddef>

#include "opencl_runtime.hpp"

namespace trilevel::test {

/// Kernel `name` of the tests' program, built on first use for the device of `rt`.
cl::Kernel test_kernel(OpenCLRuntime& rt, const char* name);

/// hash_insert_keys (tests/kernels/hash_insert_keys.cl): inserts the first `n` keys of `in` into
/// the table `keys` of `capacity` slots, writing each key's slot (-1: the table is full) to
/// `slot_of` and counting into `stats` (overflow flag, keys inserted), as hash_table.cl's
/// hash_insert_counted does for every table of the pipeline. Waits for the kernel to finish.
void hash_insert_keys(OpenCLRuntime& rt, const cl::Buffer& in, std::size_t n, const cl::Buffer& keys,
                      std::size_t capacity, const cl::Buffer& slot_of, const cl::Buffer& stats);

}  // namespace trilevel::test
