// Transition continuity (paper §3.3.1, DESIGN §7, pipeline stage 8).
#pragma once

#include <vector>

#include "coarse_cells.hpp"
#include "fine_point_map.hpp"

namespace trilevel {

/// Every lattice point present in `field` that lies on the closed boundary of a level-2 cell but
/// not on the level-2 lattice (some coordinate odd) gets the level-2 interpolation of its
/// neighbours: one odd coordinate -> lattice::edge_midpoint_value(lower, upper) along that axis;
/// two -> lattice::face_centre_value of the four diagonal neighbours, ordered (-,-), (+,-),
/// (-,+), (+,+) over the two odd axes (lower axis first). Reads only level-2 lattice points, so it
/// is idempotent and deterministic; runs in parallel over the level-2 cells.
void apply_transition_continuity(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                 FinePointMap& field);

}  // namespace trilevel
