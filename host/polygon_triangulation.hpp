// Triangulation of a planar region bounded by closed loops (outer boundaries with holes, nested to
// any depth) by ear clipping, the holes first joined to their outer boundary by bridges (Eberly,
// "Triangulation by Ear Clipping", 2002). Every loop vertex is used and no vertex is added, so the
// triangles' boundary edges are exactly the loops' edges: the caps of host/mesh_clip.hpp close a cut
// mesh by index with them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace trilevel {

struct Point2 {
    double x = 0.0, y = 0.0;
};

struct LoopTriangulation {
    std::vector<std::uint32_t> triangles;  ///< three vertex ids per triangle, counter-clockwise
    std::size_t forced = 0;  ///< triangles cut without a valid ear (self-touching or crossing input):
                             ///< they keep the index closure but may overlap or be turned over
};

/// Triangulates the region of winding number one of `loops`: each a closed sequence of vertex ids
/// (indices into `points`, each id in one loop only, a loop's last vertex joined to its first),
/// counter-clockwise around filled regions and clockwise around holes; loops must not cross. A
/// hole belongs to the smallest counter-clockwise loop around it. Loops of fewer than 3 vertices
/// bound nothing and are skipped. A clockwise loop that no counter-clockwise loop holds is
/// triangulated on its own, as a clockwise region (the index closure is kept). Groups are
/// triangulated in parallel and concatenated in the order of their outer loops: deterministic.
LoopTriangulation triangulate_loops(const std::vector<Point2>& points, const std::vector<std::vector<std::uint32_t>>& loops);

}  // namespace trilevel
