// Host view of the open-addressing hash of fine lattice points (docs/design.md §5): the key and value
// arrays as the device filled them, probed with the same hash and linear probing. Keys are stored
// in the frame's lattice::KeyLayout (4 or 8 bytes); lookups take lattice::pack() keys, whose hash
// gives the home slot whatever the storage.
#pragma once

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "core/lattice.hpp"

namespace trilevel {

class FinePointMap {
public:
    FinePointMap() = default;
    /// Takes arrays read back from the device in the default (64-bit) layout; `keys.size()` must
    /// be a multiple of 8.
    FinePointMap(std::vector<std::uint64_t> keys, std::vector<float> values)
        : own_keys_(std::move(keys)), own_values_(std::move(values)) {
        bind_own();
    }
    /// An empty table with room for `capacity` keys (lattice::table_capacity), default layout.
    explicit FinePointMap(std::size_t capacity) {
        const std::size_t c = lattice::table_capacity(capacity);
        own_keys_.assign(c, lattice::kEmptyKey);
        own_values_.assign(c, 0.0f);
        bind_own();
    }
    /// A view of arrays held elsewhere (a mapped device buffer: no host copy on CPU devices), keys
    /// stored in `layout`; valid while they are. Copies of a view are views of the same arrays.
    static FinePointMap view(void* keys, float* values, std::size_t capacity, const lattice::KeyLayout& layout) {
        FinePointMap m;
        m.bind(keys, values, capacity, layout, false);
        return m;
    }

    /// A table of its own holding what `m` holds now, in m's layout and slots (for a frame whose
    /// host stages run after its device buffers went back to the pool: FramePipeline).
    static FinePointMap copy_of(const FinePointMap& m) {
        FinePointMap c;
        const std::size_t words = m.layout_.wide ? m.capacity_ : m.capacity_ / 2;  // 4-byte keys: two a word (capacity: a multiple of 8)
        const auto* k = static_cast<const std::uint64_t*>(m.keys_);
        c.own_keys_.assign(k, k + words);
        c.own_values_.assign(m.values_, m.values_ + m.capacity_);
        c.bind(c.own_keys_.data(), c.own_values_.data(), m.capacity_, m.layout_, true);
        return c;
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

    /// Calls f(keys) with the key array as `const K*`, K = uint32_t or uint64_t, so that a hot
    /// loop branches on the layout once, not per probe.
    template <class F>
    decltype(auto) with_keys(F&& f) const {
        if (layout_.wide) return f(static_cast<const std::uint64_t*>(keys_));
        return f(static_cast<const std::uint32_t*>(keys_));
    }
    /// The slot of packed key `key` (lattice::pack) in `keys`, or -1 when absent.
    template <class K>
    std::int64_t probe(const K* keys, std::uint64_t key) const {
        const K stored = K(layout_.compact(lattice::unpack(key)));
        for (std::uint64_t s = lattice::home_slot(key, capacity_);; s = lattice::next_slot(s, capacity_)) {
            if (keys[s] == stored) return std::int64_t(s);
            if (keys[s] == K(layout_.empty())) return -1;
        }
    }

    /// The value of packed key `key` (lattice::pack), or nullptr when absent.
    const float* find(std::uint64_t key) const {
        if (capacity_ == 0) return nullptr;
        const std::int64_t s = with_keys([&](const auto* keys) { return probe(keys, key); });
        return s < 0 ? nullptr : &values_[s];
    }
    float* find(std::uint64_t key) { return const_cast<float*>(std::as_const(*this).find(key)); }
    const float* find(glm::ivec3 p) const { return find(lattice::pack(p)); }
    float* find(glm::ivec3 p) { return find(lattice::pack(p)); }

    /// Looks up `n` packed keys at once: prefetches every home slot first so that the misses
    /// overlap, then probes. out[i] = pointer to the value of keys[i], or nullptr when absent.
    template <class Value>
    void find_batch(const std::uint64_t* keys, std::size_t n, Value** out) const {
        if (capacity_ == 0) {
            for (std::size_t i = 0; i < n; ++i) out[i] = nullptr;
            return;
        }
        with_keys([&](const auto* table) {
            for (std::size_t i = 0; i < n; ++i) {
                const std::uint64_t home = lattice::home_slot(keys[i], capacity_);
                __builtin_prefetch(table + home);
                __builtin_prefetch(values_ + home);
            }
            for (std::size_t i = 0; i < n; ++i) {
                const std::int64_t s = probe(table, keys[i]);
                out[i] = s < 0 ? nullptr : values_ + s;
            }
        });
    }

    /// Inserts (or overwrites) a value; the caller keeps the load factor <= 0.5.
    float& insert(std::uint64_t key, float value) {
        std::uint64_t s = lattice::home_slot(key, capacity_);
        const std::uint64_t stored = layout_.compact(lattice::unpack(key));
        while (stored_key(s) != stored && stored_key(s) != layout_.empty()) s = lattice::next_slot(s, capacity_);
        if (layout_.wide) static_cast<std::uint64_t*>(keys_)[s] = stored;
        else static_cast<std::uint32_t*>(keys_)[s] = std::uint32_t(stored);
        values_[s] = value;
        return values_[s];
    }

    /// The packed key (lattice::pack) held in slot `s`, or lattice::kEmptyKey.
    std::uint64_t key_at(std::size_t s) const {
        const std::uint64_t k = stored_key(s);
        return k == layout_.empty() ? lattice::kEmptyKey : lattice::pack(layout_.point(k));
    }

    std::size_t capacity() const { return capacity_; }
    const lattice::KeyLayout& layout() const { return layout_; }
    std::span<float> values() { return {values_, capacity_}; }
    std::span<const float> values() const { return {values_, capacity_}; }

private:
    std::vector<std::uint64_t> own_keys_;  // empty for a view
    std::vector<float> own_values_;
    void* keys_ = nullptr;
    float* values_ = nullptr;
    std::size_t capacity_ = 0;
    lattice::KeyLayout layout_;
    bool owning_ = true;

    std::uint64_t stored_key(std::size_t s) const {
        return layout_.wide ? static_cast<const std::uint64_t*>(keys_)[s] : static_cast<const std::uint32_t*>(keys_)[s];
    }
    void bind(void* k, float* v, std::size_t capacity, const lattice::KeyLayout& layout, bool owning) {
        keys_ = k;
        values_ = v;
        capacity_ = capacity;
        layout_ = layout;
        owning_ = owning;
    }
    void bind_own() { bind(own_keys_.data(), own_values_.data(), own_keys_.size(), lattice::KeyLayout{}, true); }
    void rebind(const FinePointMap& o) {
        if (o.owning_) bind(own_keys_.data(), own_values_.data(), o.capacity_, o.layout_, true);
        else bind(o.keys_, o.values_, o.capacity_, o.layout_, false);
    }
};

}  // namespace trilevel
