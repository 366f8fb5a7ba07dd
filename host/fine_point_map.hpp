// Host view of the open-addressing hash of fine lattice points (DESIGN §5): the key and value
// arrays as the device filled them, probed with the same hash and linear probing.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "lattice.hpp"

namespace trilevel {

class FinePointMap {
public:
    FinePointMap() = default;
    /// Wraps arrays read back from the device; `keys.size()` must be a power of two.
    FinePointMap(std::vector<std::uint64_t> keys, std::vector<float> values)
        : keys_(std::move(keys)), values_(std::move(values)), mask_(keys_.size() - 1) {}
    /// An empty table with room for `capacity` keys (rounded up to a power of two).
    explicit FinePointMap(std::size_t capacity) {
        std::size_t c = 16;
        while (c < capacity) c *= 2;
        keys_.assign(c, lattice::kEmptyKey);
        values_.assign(c, 0.0f);
        mask_ = c - 1;
    }

    const float* find(std::uint64_t key) const {
        for (std::uint64_t s = lattice::hash(key) & mask_;; s = (s + 1) & mask_) {
            if (keys_[s] == key) return &values_[s];
            if (keys_[s] == lattice::kEmptyKey) return nullptr;
        }
    }
    float* find(std::uint64_t key) { return const_cast<float*>(std::as_const(*this).find(key)); }
    const float* find(glm::ivec3 p) const { return find(lattice::pack(p)); }
    float* find(glm::ivec3 p) { return find(lattice::pack(p)); }

    /// Inserts (or overwrites) a value; the caller keeps the load factor <= 0.5.
    float& insert(std::uint64_t key, float value) {
        std::uint64_t s = lattice::hash(key) & mask_;
        while (keys_[s] != key && keys_[s] != lattice::kEmptyKey) s = (s + 1) & mask_;
        keys_[s] = key;
        values_[s] = value;
        return values_[s];
    }

    /// Makes room for `extra` more keys at load factor <= 0.5, rehashing into a larger table if needed.
    void reserve_more(std::size_t extra) {
        std::size_t used = 0;
        for (std::uint64_t k : keys_) used += k != lattice::kEmptyKey;
        if (2 * (used + extra) <= keys_.size()) return;
        FinePointMap bigger(2 * (used + extra));
        for (std::size_t s = 0; s < keys_.size(); ++s)
            if (keys_[s] != lattice::kEmptyKey) bigger.insert(keys_[s], values_[s]);
        *this = std::move(bigger);
    }

    std::size_t capacity() const { return keys_.size(); }
    const std::vector<std::uint64_t>& keys() const { return keys_; }
    std::vector<float>& values() { return values_; }
    const std::vector<float>& values() const { return values_; }

private:
    std::vector<std::uint64_t> keys_;
    std::vector<float> values_;
    std::uint64_t mask_ = 0;
};

}  // namespace trilevel
