// Temporal coherence of the levels across the frames of a sequence (docs/design.md §3.2).
//
// The coarse lattice is global: its origin is a whole number of coarse cells (make_grid in
// src/reconstructor.cpp), so coarse cell c of a frame whose origin is `base` coarse cells from
// the world origin is global cell c + base, the same region of space in every frame. The history
// keeps the levels of the previous frame's cells under their global coordinates, so that
// hysteresis can hold a cell at its previous level while its curvature stays near the threshold,
// and so that the flips between frames can be counted.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/cell_index.hpp"
#include "core/coarse_cells.hpp"

namespace trilevel {

/// Global coordinates, in coarse cells, of a frame's coarse cell (0, 0, 0).
using CoarseBase = std::array<std::int64_t, 3>;

class LevelHistory {
public:
    /// Forgets the previous frame: the next frame is the first of a sequence.
    void reset() { levels_ = CellIndex(std::vector<CoarseCell>{}), valid_ = false; }
    bool empty() const { return !valid_; }

    /// The previous frame's level of each cell of `cells` (0 where it had no such cell); empty
    /// without a previous frame. Taken once a frame: apply(), check_scale() and the isolated
    /// pieces' limit (isolated_pieces.hpp) read it.
    std::vector<std::uint8_t> previous_levels(const std::vector<CoarseCell>& cells, const CoarseBase& base) const;

    /// Hysteresis on the levels the curvature pass chose (paper eq. 3 against `threshold`), with
    /// `previous` from previous_levels(cells). A cell of the previous frame that was level 3 stays 3
    /// while its curvature is >= threshold (1 - h); one that was level 2 stays 2 while its curvature
    /// is < threshold (1 + h). Cells near splash or thin particles (`forced`) keep level 3, cells
    /// new to this frame keep the level the curvature gave them. Returns how many cells it held at
    /// a level other than that one (none with `previous` empty or h = 0).
    static std::size_t apply(std::vector<CoarseCell>& cells, const std::vector<float>& curvature,
                             const std::vector<std::uint8_t>& forced, const std::vector<std::uint8_t>& previous,
                             float threshold, float h);

    /// Hysteresis for the level-2 check (level2_check.hpp), one factor per cell on its tolerance,
    /// from `previous` (previous_levels): 1 - h where the previous frame had the cell at level 3 (it
    /// stays there unless its lattice error falls clearly below the tolerance), 1 + h where it had
    /// it at level 2, 1 for cells new to this frame. Empty with `previous` empty or h = 0.
    static std::vector<float> check_scale(const std::vector<std::uint8_t>& previous, float h);

    /// Cells of `cells` that the previous frame had too, and how many of them changed level.
    struct Flips {
        std::size_t compared = 0, changed = 0;
    };
    Flips compare(const std::vector<CoarseCell>& cells, const CoarseBase& base) const;

    /// Remembers the final levels of this frame (after band closure) for the next one.
    void record(const std::vector<CoarseCell>& cells, const CoarseBase& base);

private:
    /// The previous frame's level of global cell `c + base`, or 0 when it had no such cell.
    std::uint8_t previous(glm::ivec3 c, const CoarseBase& base) const;

    CellIndex levels_{std::vector<CoarseCell>{}};  ///< the previous frame's cells, coordinates relative to base_
    CoarseBase base_{};
    bool valid_ = false;
};

}  // namespace trilevel
