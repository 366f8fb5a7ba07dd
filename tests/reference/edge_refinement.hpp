// Level-2 edge refinement: one bisection step for the vertices of flat regions.
//
// Beyond the paper: a crossing on a level-2 edge (2 lattice steps) is placed on the unit sub-edge
// whose end signs differ, interpolating with the edge's midpoint value (docs/design.md §7 vertex rule).
// Where no level-3 cell shares the edge, the midpoint is not constrained by transition
// continuity, so its true field value can be used: the vertex then lands where the uniform
// cell-r mesh puts it, while the level-2 triangle count stays the same. Costs one scalar-field
// evaluation per level-2 vertex. The pipeline finds, inserts and evaluates these midpoints on the
// device in one pass (refine_edges, src/device_stages.hpp); this file is its
// definition in plain C++, for the tests (built into their library only).
#pragma once

#include <cstdint>
#include <vector>

#include "core/coarse_cells.hpp"
#include "core/fine_point_map.hpp"

namespace trilevel {

/// Keys (sorted, unique) of the midpoints of the level-2 edges of the level-2 cells in `cells`
/// whose end values in `field` differ in sign (mc::inside) and that `field` does not hold yet.
/// Edges with an end missing from `field` are skipped.
std::vector<std::uint64_t> edge_refinement_points(const std::vector<CoarseCell>& cells,
                                                  const LatticeFrame& lattice_frame, const FinePointMap& field);

// The level-2 midpoint rule (the surface mesher and crack stitching apply it inline, on batched
// lookups): the value at the midpoint of a level-2 edge with end values va, vb is the field's value
// when the field holds the point (a refined or continuity point), else
// lattice::edge_midpoint_value(va, vb).

}  // namespace trilevel
