// Level-2 edge refinement: one bisection step for the vertices of flat regions.
//
// Beyond the paper: a crossing on a level-2 edge (2 lattice steps) is placed on the unit sub-edge
// whose end signs differ, interpolating with the edge's midpoint value (DESIGN §7 vertex rule).
// Where no level-3 cell shares the edge, the midpoint is not constrained by transition
// continuity, so its true field value can be used: the vertex then lands where the uniform
// cell-r mesh puts it, while the level-2 triangle count stays the same. Costs one scalar-field
// evaluation per level-2 vertex.
#pragma once

#include <cstdint>
#include <vector>

#include "coarse_cells.hpp"
#include "fine_point_map.hpp"

namespace trilevel {

/// The midpoints to evaluate, each listed once under one level-2 cell that holds it.
struct Level2Midpoints {
    std::vector<std::uint64_t> keys;  ///< unique; holder by holder, each holder's in ascending order
    std::vector<CoarseCell> holders;  ///< level-2 cells holding at least one, in the input order
    std::vector<std::uint32_t> first;  ///< holder h lists keys[first[h] .. first[h + 1]) (maybe none)
};

/// Midpoints of level-2 edges that the surface crosses (end signs differ) and that `field` does
/// not hold yet, each listed under the first cell of `cells` that holds its edge (up to four do),
/// so that the device evaluates it without claiming. Holders with empty lists stay: where a
/// holder's candidates do not fit, the others claim its points (scalar_field.cl).
Level2Midpoints level2_crossing_midpoints(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                          const FinePointMap& field);

// The level-2 midpoint rule (the surface mesher and crack stitching apply it inline, on batched
// lookups): the value at the midpoint of a level-2 edge with end values va, vb is the field's value
// when the field holds the point (a refined or continuity point), else
// lattice::edge_midpoint_value(va, vb).

}  // namespace trilevel
