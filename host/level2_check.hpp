// The level-2 check (beyond the paper; docs/design.md §3.2): a coarse cell that curvature left at level 2
// is meshed with cells of r after all where its level-2 lattice misses the field. The field phi is
// a signed distance (docs/design.md §3.3), so the gap between its true value at the centre of a level-2
// cube and the trilinear value there (the mean of the cube's corners) is about how far the
// level-2 surface would stand off the true one near that point. Curvature from particle normals
// misses thin sheets and ridges and fires on disordered particles on flat water; this check
// measures the lattice error itself, at one extra point per level-2 cube (the cube centres are
// level-3 points, so a promoted cell reuses them). The centres of the checked cells are inserted
// and evaluated with the cells' own points (refine_and_evaluate's cube_centres flags).
#pragma once

#include <cstdint>
#include <vector>

#include "core/coarse_cells.hpp"
#include "core/fine_point_map.hpp"

namespace trilevel {

/// Indices into `cells` (ascending) of the level-2 cells with `checked` set to make level 3:
/// those with a cube that the surface crosses (its 8 corners and centre hold both signs) and whose
/// centre value differs from the mean of its corners by more than `tolerance` (world units). Only
/// the failing cell: with the crack collapse a lone level-3 cell no longer costs crack patches on
/// its faces, and the 3x3x3 block that each failing cell once took with it (while it did) cost
/// more triangles than accuracy (docs/design.md, "Level-2 check"). Every corner and centre of a
/// checked cell must be in `field` (throws Error). `scale`, empty or one factor per cell, multiplies
/// the tolerance cell by cell: the level history's hysteresis (level_history.hpp, check_scale).
std::vector<std::size_t> cells_failing_level2_check(const std::vector<CoarseCell>& cells,
                                                    const std::vector<std::uint8_t>& checked,
                                                    const LatticeFrame& lattice_frame,
                                                    const FinePointMap& field, float tolerance,
                                                    const std::vector<float>& scale = {});

}  // namespace trilevel
