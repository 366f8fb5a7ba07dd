// Transition continuity (paper §3.3.1, docs/design.md §7, pipeline stage 8).
#pragma once

#include <vector>

#include "core/cell_index.hpp"
#include "core/coarse_cells.hpp"
#include "core/fine_point_map.hpp"

namespace trilevel {

/// Every lattice point present in `field` that is the midpoint of an edge of the level-2 lattice
/// (one odd coordinate) on the closed boundary of a level-2 cell of `cells`, belongs to a level-3
/// cell of `cells` and whose edge the surface does not cross (its ends have the same sign, as
/// mc::inside sees them) gets lattice::edge_midpoint_value(lower, upper) of the ends along that
/// axis. That is all the watertight meshing needs: the level-3 side then finds no crossing on an
/// edge the level-2 side sees as uncrossed, and the crossing on a crossed edge lies on the sub-edge
/// whose ends differ for both sides alike, as both read the same midpoint value.
///
/// Beyond the paper (§3.3.1 interpolates every level-3 point on such faces and edges, docs/design.md §7):
/// crossed edges keep the field's midpoint value, so their vertex lands where the uniform cell-r
/// mesh puts it, as tests/reference/edge_refinement.hpp does for the other level-2 edges, and the centres of
/// level-2 squares (two odd coordinates) keep theirs too; the crack stitcher closes the faces for
/// any values there: closer to the uniform r mesh at the same triangle count (docs/design.md §7).
/// Only level-2 cells with a level-3 face or edge neighbour do work (paper §3.3.1). Reads only
/// level-2 lattice points, so it is idempotent and deterministic; parallel (TBB).
/// Throws Error when a level-2 point of such a cell is missing from `field`.
void apply_transition_continuity(const std::vector<CoarseCell>& cells, const LatticeFrame& lattice_frame,
                                 FinePointMap& field);
/// The same with `index`, a CellIndex of `cells` the caller already has (band closure takes the same one).
void apply_transition_continuity(const std::vector<CoarseCell>& cells, const CellIndex& index,
                                 const LatticeFrame& lattice_frame, FinePointMap& field);

}  // namespace trilevel
