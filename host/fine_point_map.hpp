// Host view of the open-addressing hash of fine lattice points (DESIGN §5): the key and value
// arrays as the device filled them, probed with the same hash and linear probing.
#pragma once

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "lattice.hpp"

namespace trilevel {

class FinePointMap {
public:
    FinePointMap() = default;
    /// Takes arrays read back from the device; `keys.size()` must be a multiple of 8.
    FinePointMap(std::vector<std::uint64_t> keys, std::vector<float> values)
        : own_keys_(std::move(keys)), own_values_(std::move(values)) {
        bind_own();
    }
    /// An empty table with room for `capacity` keys (lattice::table_capacity).
    explicit FinePointMap(std::size_t capacity) {
        const std::size_t c = lattice::table_capacity(capacity);
        own_keys_.assign(c, lattice::kEmptyKey);
        own_values_.assign(c, 0.0f);
        bind_own();
    }
    /// A view of arrays held elsewhere (a mapped device buffer: no host copy on CPU devices);
    /// valid while they are. Copies of a view are views of the same arrays.
    static FinePointMap view(std::uint64_t* keys, float* values, std::size_t capacity) {
        FinePointMap m;
        m.bind(keys, values, capacity, false);
        return m;
    }

    FinePointMap(const FinePointMap& o) : own_keys_(o.own_keys_), own_values_(o.own_values_) { rebind(o); }
    FinePointMap(FinePointMap&& o) noexcept
        : own_keys_(std::move(o.own_keys_)), own_values_(std::move(o.own_values_)) {
        rebind(o);
    }
    FinePointMap& operator=(FinePointMap o) noexcept {
        own_keys_ = std::move(o.own_keys_);
        own_values_ = std::move(o.own_values_);
        rebind(o);
        return *this;
    }

    const float* find(std::uint64_t key) const {
        for (std::uint64_t s = lattice::home_slot(key, capacity_);; s = lattice::next_slot(s, capacity_)) {
            if (keys_[s] == key) return &values_[s];
            if (keys_[s] == lattice::kEmptyKey) return nullptr;
        }
    }
    float* find(std::uint64_t key) { return const_cast<float*>(std::as_const(*this).find(key)); }
    const float* find(glm::ivec3 p) const { return find(lattice::pack(p)); }
    float* find(glm::ivec3 p) { return find(lattice::pack(p)); }

    /// Inserts (or overwrites) a value; the caller keeps the load factor <= 0.5.
    float& insert(std::uint64_t key, float value) {
        std::uint64_t s = lattice::home_slot(key, capacity_);
        while (keys_[s] != key && keys_[s] != lattice::kEmptyKey) s = lattice::next_slot(s, capacity_);
        keys_[s] = key;
        values_[s] = value;
        return values_[s];
    }

    std::size_t capacity() const { return capacity_; }
    std::span<const std::uint64_t> keys() const { return {keys_, capacity_}; }
    std::span<float> values() { return {values_, capacity_}; }
    std::span<const float> values() const { return {values_, capacity_}; }

private:
    std::vector<std::uint64_t> own_keys_;  // empty for a view
    std::vector<float> own_values_;
    std::uint64_t* keys_ = nullptr;
    float* values_ = nullptr;
    std::size_t capacity_ = 0;
    bool owning_ = true;

    void bind(std::uint64_t* k, float* v, std::size_t capacity, bool owning) {
        keys_ = k;
        values_ = v;
        capacity_ = capacity;
        owning_ = owning;
    }
    void bind_own() { bind(own_keys_.data(), own_values_.data(), own_keys_.size(), true); }
    void rebind(const FinePointMap& o) {
        if (o.owning_) bind_own();
        else bind(o.keys_, o.values_, o.capacity_, false);
    }
};

}  // namespace trilevel
