// Isolated pieces of fluid at level 3 (paper Fig. 1: "cells around the isolated pieces are always
// level-3"). A droplet of a few dozen particles is a small, separate group of coarse surface cells;
// its curvature (paper eq. 1, a sum over neighbours) stays small because it has few neighbours, so
// the curvature test leaves it at level 2, whose lattice of 2r loses a third of its volume.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/coarse_cells.hpp"

namespace trilevel {

/// The connected groups of `cells`, two cells joined when they share a face: each cell's group,
/// numbered 0, 1, ... in the order of the groups' first cells, and each group's size in cells.
/// Faces, not the 26 neighbours: surface cells are those within 2r of a surface particle, so two
/// bodies 8r apart (four particle spacings) can have cells that touch at an edge or a corner, and
/// a droplet passing over the pool joined it and dropped to level 2 more often (scene falling-drop:
/// 827 level flips in 60 frames against 586).
struct CellGroups {
    std::vector<std::uint32_t> group;  ///< per cell
    std::vector<std::uint32_t> size;   ///< per group
};
CellGroups cell_groups(const std::vector<CoarseCell>& cells);

/// Sets level 3 and the forced flag (`forced`, one per cell) on every cell whose group has at most
/// `max_cells` cells; 0 turns the rule off. Returns how many cells it turned from level 2 to 3.
///
/// Hysteresis over the frames of a sequence (level_history.hpp): `previous`, empty or one per cell,
/// is the level the previous frame gave the cell (0: it had none). A group most of whose earlier
/// cells were level 3 stays isolated up to max_cells (1 + h) cells, one whose earlier cells were
/// mostly level 2 becomes isolated at max_cells (1 - h): a droplet that wobbles around the limit
/// keeps its level instead of switching its whole surface between frames.
std::size_t promote_isolated_pieces(std::vector<CoarseCell>& cells, std::vector<std::uint8_t>& forced,
                                    std::size_t max_cells, const std::vector<std::uint8_t>& previous = {},
                                    float h = 0.0f);

}  // namespace trilevel
