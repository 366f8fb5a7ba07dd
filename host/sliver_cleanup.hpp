// Sliver cleanup (Params::sliver_cleanup): marching cubes puts two crossings of a cube's edges
// close together where the surface passes near a lattice point, and the triangle between them is
// a needle. Each such short edge is collapsed by index (edge_collapse.hpp): its two ends become
// one vertex, the two needles on it vanish, and the mesh stays a closed oriented 2-manifold.
// Lattice levels play no part (a collapse only looks at the triangles around the edge), so it
// works across the transitions of an adaptive mesh as anywhere else.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel {

/// Edge ratio under which a triangle counts as a needle: its shortest edge against its longest.
/// 0.15 catches the triangles with an angle under about 8.6 degrees at the short edge.
constexpr double kSliverEdgeRatio = 0.15;

/// Collapses the shortest edge of every triangle whose shortest edge is under kSliverEdgeRatio
/// times its longest, the higher-numbered end into the lower (which keeps its position: the move
/// is the short edge's length), where that keeps the mesh a closed oriented 2-manifold, turns no
/// triangle over and moves none through another. The edges are taken in triangle order within
/// tiles across the mesh, far enough apart to be collapsed on several threads at once (a quarter
/// of the tiles at a time; sliver_cleanup.cpp): the result is the same on any number of threads.
/// Removes the dead vertices and triangles (order of the rest kept) and returns the number of
/// edges collapsed. `kept`, where given, receives the old index of each vertex left, ascending
/// (no vertex moves: a vertex's data computed before carries over).
std::size_t collapse_slivers(Mesh& mesh, std::vector<std::uint32_t>* kept = nullptr);

}  // namespace trilevel
