// Lookup helpers of the host stages: coarse cell coordinates -> level, and batched fine-point
// lookups that overlap their cache misses (docs/design.md §4: sparse structures only).
#pragma once

#include <cstdint>
#include <vector>

#include "core/coarse_cells.hpp"
#include "core/fine_point_map.hpp"

namespace trilevel {

/// Open-addressing set of coarse cells keyed by lattice::pack(coord), holding each cell's level
/// and its position in the list it was built from.
class CellIndex {
public:
    explicit CellIndex(const std::vector<CoarseCell>& cells) {
        std::size_t c = 16;
        while (c < 2 * cells.size()) c *= 2;
        keys_.assign(c, lattice::kEmptyKey);
        levels_.assign(c, 0);
        positions_.resize(c);
        mask_ = c - 1;
        for (std::size_t i = 0; i < cells.size(); ++i) {
            const std::uint64_t k = lattice::pack(cells[i].coord);
            std::uint64_t s = lattice::hash(k) & mask_;
            while (keys_[s] != lattice::kEmptyKey && keys_[s] != k) s = (s + 1) & mask_;
            keys_[s] = k;
            levels_[s] = cells[i].level;
            positions_[s] = std::uint32_t(i);  // a repeated coordinate keeps its last
        }
    }
    /// The level of the cell at `coord`, or 0 when absent (negative coordinates are absent).
    int level(glm::ivec3 coord) const {
        const std::int64_t s = slot(coord);
        return s < 0 ? 0 : levels_[std::size_t(s)];
    }
    /// The position in the building list of the cell at `coord`, or -1 when absent.
    std::int64_t position(glm::ivec3 coord) const {
        const std::int64_t s = slot(coord);
        return s < 0 ? -1 : std::int64_t(positions_[std::size_t(s)]);
    }

private:
    std::vector<std::uint64_t> keys_;
    std::vector<std::uint8_t> levels_;
    std::vector<std::uint32_t> positions_;
    std::uint64_t mask_ = 0;

    std::int64_t slot(glm::ivec3 coord) const {
        if (coord.x < 0 || coord.y < 0 || coord.z < 0) return -1;
        const std::uint64_t k = lattice::pack(coord);
        for (std::uint64_t s = lattice::hash(k) & mask_;; s = (s + 1) & mask_) {
            if (keys_[s] == k) return std::int64_t(s);
            if (keys_[s] == lattice::kEmptyKey) return -1;
        }
    }
};

/// Looks up `n` packed keys at once (FinePointMap::find_batch): out[i] = pointer to the value
/// of keys[i], or nullptr when absent.
template <class Map, class Value>
void find_batch(Map& map, const std::uint64_t* keys, std::size_t n, Value** out) {
    map.find_batch(keys, n, out);
}

/// Looks up the level-2 lattice points of coarse cell `coord` (every second point, (cs/2+1)^3 of
/// them, x fastest) with find_batch: `keys` receives their keys, `out` their values.
template <class Map, class Value>
void find_level2_points(Map& map, glm::ivec3 coord, int cs, std::vector<std::uint64_t>& keys, std::vector<Value*>& out) {
    const int m = cs / 2 + 1;
    const glm::ivec3 base = coord * cs;
    keys.clear();
    for (int z = 0; z < m; ++z)
        for (int y = 0; y < m; ++y)
            for (int x = 0; x < m; ++x) keys.push_back(lattice::pack(base + 2 * glm::ivec3(x, y, z)));
    out.resize(keys.size());
    find_batch(map, keys.data(), keys.size(), out.data());
}

}  // namespace trilevel
