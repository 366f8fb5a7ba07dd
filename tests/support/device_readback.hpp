// Device results copied to the host for the tests to compare (the pipeline maps them instead:
// map_fine_points, src/device_stages.hpp).
#pragma once

#include "core/fine_point_map.hpp"
#include "device_stages.hpp"

namespace trilevel::test {

/// A copy of the fine-point table in the default (64-bit) key layout, whatever layout it is
/// stored in on the device.
FinePointMap read_fine_points(OpenCLRuntime& rt, const FinePoints& points);

}  // namespace trilevel::test
