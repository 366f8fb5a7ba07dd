// Transition continuity (paper §3.3.1, DESIGN §7, pipeline stage 8).
#pragma once

#include <vector>

#include "coarse_cells.hpp"
#include "fine_point_map.hpp"

namespace trilevel {

/// Every lattice point present in `field` that lies on the closed boundary of a level-2 cell of
/// `cells` and belongs to a level-3 cell of `cells` (so not on the level-2 lattice: some coordinate
/// odd) gets the level-2 interpolation of its neighbours: one odd coordinate ->
/// lattice::edge_midpoint_value(lower, upper) along that axis; two -> lattice::face_centre_value
/// of the four diagonal neighbours, ordered (-,-), (+,-), (-,+), (+,+) over the two odd axes (lower
/// axis first). Only level-2 cells with a level-3 face or edge neighbour do work (paper §3.3.1).
/// Reads only level-2 lattice points, so it is idempotent and deterministic; parallel (TBB).
/// Throws Error when a level-2 point of such a cell is missing from `field`.
void apply_transition_continuity(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                 FinePointMap& field);

}  // namespace trilevel
