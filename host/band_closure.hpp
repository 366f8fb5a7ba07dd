// Band closure (docs/design.md §2 stage 7, §7): no iso-surface crossing may sit on a face of the cell set
// whose neighbour is missing.
#pragma once

#include <vector>

#include "core/cell_index.hpp"
#include "core/coarse_cells.hpp"
#include "core/fine_point_map.hpp"

namespace trilevel {

/// The face neighbours missing from `cells` across which the surface leaves the set: a face
/// whose lattice points (at its cell's stride, values after continuity) hold both signs
/// (< 0 and >= 0). Sorted by lattice::pack(coord), unique; each gets the largest level among the
/// cells that triggered it. Throws trilevel::Error when such a neighbour falls outside the domain
/// (a coordinate < 0, or a lattice point beyond lattice::kMaxCoord) or a needed point is missing
/// from `field`. The caller evaluates the new cells' points and calls
/// again until the result is empty.
std::vector<CoarseCell> band_closure_cells(const std::vector<CoarseCell>& cells, const LatticeFrame& lattice_frame,
                                           const FinePointMap& field);
/// The same with `index`, a CellIndex of `cells` the caller already has.
std::vector<CoarseCell> band_closure_cells(const std::vector<CoarseCell>& cells, const CellIndex& index,
                                           const LatticeFrame& lattice_frame, const FinePointMap& field);

}  // namespace trilevel
