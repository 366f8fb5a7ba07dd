// Triangulation of the coarse surface cells (paper §3.3, docs/design.md §2 stages 9-10, §6, §7).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/coarse_cells.hpp"
#include "core/fine_point_map.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {

/// Marching cubes on every fine cube of every cell (level 3: stride 1, level 2: stride 2), one
/// vertex per crossing keyed by the unit lattice edge that holds it (level-2 edges: the sub-edge
/// picked by lattice::edge_midpoint_value), then crack patches on every face between a level-3
/// and a level-2 cell. `field` must hold every point of every cell at its stride, after transition
/// continuity. Cells are processed in the given order (callers pass them sorted by pack(coord));
/// vertices are numbered by first appearance; the result is bit-identical for any thread count.
/// Closed and oriented whenever no crossing lies on a face without a neighbour (band closure).
/// CrackClosing::Collapse then merges the cracks' inner crossings into the level-2 crossings
/// (host/crack_collapse.hpp); `collapsed`, when given, receives how many vertices that removed.
/// `beside_collapse`, when set, is called with a copy of the vertex positions before the crack
/// collapse, on another host thread while the (serial) collapse runs: no collapse moves a vertex,
/// so what it computes per vertex holds for the vertices left, whose old indices `kept` receives
/// (ascending; all of them under CrackClosing::Patches). `field_done`, when set, is called once
/// `field` is read no more, before the triangles are assembled and the cracks collapsed, so that
/// the caller can free it: the table and the collapse's crossing grid are then never alive at
/// once (the peak of a large frame).
Mesh triangulate_cells(const std::vector<CoarseCell>& cells, const LatticeFrame& lattice_frame,
                       const FinePointMap& field, CrackClosing closing = CrackClosing::Collapse,
                       std::size_t* collapsed = nullptr,
                       const std::function<void(const std::vector<float>&)>& beside_collapse = {},
                       std::vector<std::uint32_t>* kept = nullptr, const std::function<void()>& field_done = {});

}  // namespace trilevel
