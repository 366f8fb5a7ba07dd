// Face-consistent marching cubes (paper §3.3, docs/design.md §7), table generated at start-up.
//
// Each cube face yields its crossing segments from its own four corner signs alone (ambiguous
// faces always separate the inside corners), oriented so that the two cubes sharing a face get
// the same segments in opposite directions. A cube's polygons are those segments chained into
// cycles and fanned, so a mesh of such cubes is closed by construction.
//
// Conventions: inside where value < 0. Cube corner i sits at offset (i&1, i>>1&1, i>>2&1).
// Cube edge e runs along axis e/4 from corner kCubeEdges[e].corner0 to corner1.
// Triangles are counter-clockwise seen from outside (normal toward increasing value).
#pragma once

#include <array>
#include <cstdint>

namespace trilevel::mc {

inline bool inside(float v) { return v < 0.0f; }

struct CubeEdge {
    int axis;
    int corner0;  ///< lower end
    int corner1;  ///< corner0 + unit(axis)
};

/// The 12 cube edges: x edges 0-3, y edges 4-7, z edges 8-11.
const std::array<CubeEdge, 12>& cube_edges();

/// Cube face 2*axis + side: corners counter-clockwise seen from outside the cube, and the cube
/// edge joining corner k to corner (k+1)%4 (face edge k).
struct CubeFace {
    std::array<int, 4> corner;
    std::array<int, 4> edge;
};
const std::array<CubeFace, 6>& cube_faces();

/// A directed face segment from the crossing on face edge `from` to the crossing on face edge `to`.
struct FaceSegment {
    std::uint8_t from;
    std::uint8_t to;
};

/// Crossing segments of one face: bit k of `inside_mask` = corner k (counter-clockwise seen from
/// the side the segments are meant for) is inside. Writes 0, 1 or 2 segments; returns the count.
/// Segments run with the inside on their right seen from that side; ambiguous faces separate the
/// inside corners. Seen from the other side (reversed corner order) the segments reverse.
int face_segments(unsigned inside_mask, std::array<FaceSegment, 2>& out);

/// Triangles of one of the 256 cases, as cube edge ids (at most 10 triangles).
struct CubeCase {
    std::uint8_t triangle_count = 0;
    std::array<std::array<std::uint8_t, 3>, 10> triangles{};
};

/// The table, generated once on first use (thread-safe static init). Case bit i = corner i inside.
const std::array<CubeCase, 256>& case_table();

inline unsigned case_index(const float v[8]) {
    unsigned c = 0;
    for (int i = 0; i < 8; ++i) c |= unsigned(inside(v[i])) << i;
    return c;
}

/// Polygonises one cube: its 8 corner values -> triangles over cube edge ids.
inline const CubeCase& polygonise(const float v[8]) { return case_table()[case_index(v)]; }

}  // namespace trilevel::mc
