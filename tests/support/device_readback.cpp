// See device_readback.hpp.
#include "support/device_readback.hpp"

#include <cstdint>
#include <utility>
#include <vector>

namespace trilevel::test {

FinePointMap read_fine_points(OpenCLRuntime& rt, const FinePoints& p) {
    std::vector<float> values = read_buffer<float>(rt, p.values, p.hash.capacity);
    if (p.layout.wide)  // the default layout: pack() itself
        return FinePointMap(read_buffer<cl_ulong>(rt, p.hash.keys, p.hash.capacity), std::move(values));
    // Into the default layout: the home slots are those of pack() whatever the storage.
    std::vector<std::uint64_t> keys(p.hash.capacity);
    const auto stored = read_buffer<std::uint8_t>(rt, p.hash.keys, p.hash.capacity * p.layout.key_bytes());
    const FinePointMap view = FinePointMap::view(const_cast<std::uint8_t*>(stored.data()), values.data(), keys.size(), p.layout);
    for (std::size_t s = 0; s < keys.size(); ++s) keys[s] = view.key_at(s);
    return FinePointMap(std::move(keys), std::move(values));
}

}  // namespace trilevel::test
