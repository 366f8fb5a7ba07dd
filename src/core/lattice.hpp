// The fine lattice shared by every stage (docs/design.md §5, paper eq. 4-6 made sparse).
//
// Lattice points have integer coordinates relative to a grid origin that lies two coarse cells
// below the particles' bounding box. A coarse cell spans `coarse_steps` lattice steps per axis;
// a level-3 cell subdivides it with stride 1, a level-2 cell with stride 2 (paper Fig. 2).
// Keys pack 20 bits per axis (x lowest) into 60 bits: injective, never equal to kEmptyKey, and
// free for vertex keys to carry an axis in the two bits above. Must match kernels/hash_table.cl.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include <glm/glm.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace trilevel::lattice {

constexpr int kAxisBits = 20;
constexpr std::int32_t kMaxCoord = (1 << kAxisBits) - 1;  ///< largest coordinate on any axis
constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};     ///< an unused hash slot

inline std::uint64_t pack(std::int32_t x, std::int32_t y, std::int32_t z) {
    return std::uint64_t(std::uint32_t(x)) | (std::uint64_t(std::uint32_t(y)) << kAxisBits) |
           (std::uint64_t(std::uint32_t(z)) << (2 * kAxisBits));
}
inline std::uint64_t pack(glm::ivec3 p) { return pack(p.x, p.y, p.z); }

inline glm::ivec3 unpack(std::uint64_t key) {
    constexpr std::uint64_t m = (std::uint64_t{1} << kAxisBits) - 1;
    return {int(key & m), int((key >> kAxisBits) & m), int((key >> (2 * kAxisBits)) & m)};
}

inline bool in_range(glm::ivec3 p) {
    return p.x >= 0 && p.y >= 0 && p.z >= 0 && p.x <= kMaxCoord && p.y <= kMaxCoord && p.z <= kMaxCoord;
}

/// How the fine-point table stores a lattice point: its coordinates packed x lowest, y from bit
/// `y_shift`, z from bit `z_shift`. The home slot is always that of pack(p), so the table's layout
/// (and every result) is the same whatever the storage. A frame whose lattice fits 32 bits stores
/// 4-byte keys (8 bytes a slot with the value instead of 12); the default
/// is pack() itself in 64 bits. Must match fine_key() in kernels/hash_table.cl.
struct KeyLayout {
    int y_shift = kAxisBits, z_shift = 2 * kAxisBits;
    bool wide = true;  ///< 64-bit keys
    glm::ivec3 max_coord{kMaxCoord};  ///< largest coordinate each axis holds

    std::uint64_t compact(glm::ivec3 p) const {
        return std::uint64_t(std::uint32_t(p.x)) | (std::uint64_t(std::uint32_t(p.y)) << y_shift) |
               (std::uint64_t(std::uint32_t(p.z)) << z_shift);
    }
    glm::ivec3 point(std::uint64_t k) const {
        return {int(k & ((std::uint64_t{1} << y_shift) - 1)), int((k >> y_shift) & ((std::uint64_t{1} << (z_shift - y_shift)) - 1)),
                int(k >> z_shift)};
    }
    std::uint64_t empty() const { return wide ? kEmptyKey : 0xffffffffull; }
    std::size_t key_bytes() const { return wide ? 8 : 4; }
    bool operator==(const KeyLayout&) const = default;
    bool holds(glm::ivec3 p) const { return glm::all(glm::greaterThanEqual(p, glm::ivec3(0))) && glm::all(glm::lessThanEqual(p, max_coord)); }
};

/// The 32-bit layout for a lattice whose points lie in [0, max_coord], when one fits: each axis
/// takes the bits of its largest coordinate, z one more than that when needed so that no key is
/// all ones (the empty slot). Otherwise the default 64-bit one.
inline KeyLayout key_layout_for(glm::ivec3 max_coord) {
    auto bits = [](std::uint32_t v) { return v == 0 ? 1 : 32 - __builtin_clz(v); };
    const int bx = bits(std::uint32_t(max_coord.x)), by = bits(std::uint32_t(max_coord.y));
    const int bz = bits(std::uint32_t(max_coord.z) + 1);  // z's field never all ones
    if (bx + by + bz > 32) return KeyLayout{};
    return KeyLayout{bx, bx + by, false, max_coord};
}

/// Hash of a key; identical to trilevel_hash() in hash_table.cl (home_slot() below maps it into a table). The
/// members of a 2x2x2 block share one run of 8 slots (one cache line of keys); points with all
/// coordinates even form such blocks on the level-2 lattice. Lookups of neighbouring points then
/// hit a few lines of a table far larger than the caches instead of one random line each.
inline std::uint64_t hash(std::uint64_t k) {
    constexpr std::uint64_t kLowestBits = 1ull | (1ull << kAxisBits) | (1ull << (2 * kAxisBits));
    if ((k & kLowestBits) == 0) k = (k >> 1) | (1ull << 63);  // halves every coordinate
    const std::uint64_t in_block = (k & 1ull) | ((k >> (kAxisBits - 1)) & 2ull) | ((k >> (2 * kAxisBits - 2)) & 4ull);
    k &= ~kLowestBits;
    k ^= k >> 30;
    k *= 0xbf58476d1ce4e5b9ull;
    k ^= k >> 27;
    k *= 0x94d049bb133111ebull;
    k ^= k >> 31;
    return (k << 3) | in_block;
}

/// Home slot of a key in a table of `capacity` slots (a multiple of 8, below 2^35); identical to
/// home_slot() in hash_table.cl, which says why. Power-of-two tables take the hash's low bits,
/// others the block's run of 8 by multiply-shift ((top 32 bits of the hash * runs) >> 32), so a
/// table needs no power-of-two size; the key's place in its block fills the low 3 bits.
inline std::uint64_t home_slot(std::uint64_t key, std::uint64_t capacity) {
    const std::uint64_t h = hash(key);
    if ((capacity & (capacity - 1)) == 0) return h & (capacity - 1);
    return ((((h >> 32) * (capacity >> 3)) >> 32) << 3) | (h & 7);
}

/// The slot after `s` in linear probing, wrapping at the end of the table.
inline std::uint64_t next_slot(std::uint64_t s, std::uint64_t capacity) { return s + 1 == capacity ? 0 : s + 1; }

/// Capacity of a device or map table with room for `n` slots: a multiple of 8, at least 16.
/// home_slot() takes tables below 2^35 slots (384 GiB of keys and values).
inline std::size_t table_capacity(std::size_t n) {
    if (n >= (std::size_t{1} << 35)) throw std::length_error("hash table of over 2^35 slots");
    return n < 16 ? 16 : (n + 7) / 8 * 8;
}

/// Morton (z-order) code of non-negative coordinates below 2^21: cells or bins that are near in
/// space are near in this order, which is how the stages lay out and visit them for the caches.
inline std::uint64_t morton(glm::ivec3 c) {
    auto spread = [](std::uint64_t v) {  // the low 21 bits of v to every third bit
        v &= 0x1fffff;
        v = (v | v << 32) & 0x1f00000000ffffULL;
        v = (v | v << 16) & 0x1f0000ff0000ffULL;
        v = (v | v << 8) & 0x100f00f00f00f00fULL;
        v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
        v = (v | v << 2) & 0x1249249249249249ULL;
        return v;
    };
    return spread(std::uint64_t(c.x)) | spread(std::uint64_t(c.y)) << 1 | spread(std::uint64_t(c.z)) << 2;
}

/// Sorts `items` by the Morton code of coord(item), each code computed once (equal codes keep
/// their order). For layouts and visits where only memory locality depends on the order. A stable
/// radix sort over the bytes of the code that vary (four or five for a frame's bins or cells):
/// x512's 1.2 M bins took 55 ms as a comparison sort of (code, index) pairs on 2 cores.
template <class T, class Coord>
void sort_by_morton(std::vector<T>& items, Coord coord) {
    struct Entry {
        std::uint64_t code;
        std::size_t index;
    };
    const std::size_t n = items.size();
    std::vector<Entry> order(n), next(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1 << 14), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) order[i] = {morton(coord(items[i])), i};
    });
    std::uint64_t any_set = 0, all_set = ~std::uint64_t{0};
    for (const Entry& e : order) {
        any_set |= e.code;
        all_set &= e.code;
    }
    for (int shift = 0; shift < 64; shift += 8) {
        if ((((any_set ^ all_set) >> shift) & 0xff) == 0) continue;  // the same byte in every code
        std::size_t start[257] = {};
        for (const Entry& e : order) ++start[((e.code >> shift) & 0xff) + 1];
        for (int d = 0; d < 256; ++d) start[d + 1] += start[d];
        for (const Entry& e : order) next[start[(e.code >> shift) & 0xff]++] = e;
        order.swap(next);
    }
    std::vector<T> sorted;
    sorted.reserve(n);
    for (const Entry& e : order) sorted.push_back(items[e.index]);
    items.swap(sorted);
}

/// A vertex lies on the lattice edge from point `p` to p + unit(axis): key = point key | axis << 60.
inline std::uint64_t edge_key(glm::ivec3 p, int axis) { return pack(p) | (std::uint64_t(axis) << 60); }

/// Value at the midpoint of an uncrossed level-2 edge (paper §3.3.1, docs/design.md §7). The same
/// expression serves transition continuity and the level-2 vertex rule, so both sides of a
/// transition face compute bit-identical values.
inline float edge_midpoint_value(float a, float b) { return 0.5f * (a + b); }

}  // namespace trilevel::lattice
