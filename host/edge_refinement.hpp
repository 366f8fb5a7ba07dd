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

/// The midpoints to evaluate and the level-2 cells that hold them.
struct Level2Midpoints {
    std::vector<std::uint64_t> keys;  ///< sorted, unique
    std::vector<CoarseCell> holders;  ///< level-2 cells with at least one of them, in the input order
};

/// Midpoints of level-2 edges that the surface crosses (end signs differ) and that `field` does
/// not hold yet. Run after band closure and continuity.
Level2Midpoints level2_crossing_midpoints(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                          const FinePointMap& field);

// The level-2 midpoint rule (the surface mesher and crack stitching apply it inline, on batched
// lookups): the value at the midpoint of a level-2 edge with end values va, vb is the field's value
// when the field holds the point (a refined or continuity point), else
// lattice::edge_midpoint_value(va, vb).

}  // namespace trilevel
