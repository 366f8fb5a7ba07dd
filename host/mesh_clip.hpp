// Clipping a closed mesh to an axis-aligned box and closing it there. Each face of the box cuts
// the mesh in turn: triangles outside the face's half-space go, the crossing ones are cut at the
// plane (new vertices exactly on it, one per cut edge, shared by the edge's two triangles), and
// the loops the cut leaves are closed with a flat cap (host/polygon_triangulation.hpp: outer
// boundaries with holes, nested), oriented outward. A closed, consistently oriented mesh stays
// closed and oriented by index after every face.
#pragma once

#include <cstddef>

#include "trilevel/trilevel.hpp"

namespace trilevel {

struct ClipCounts {
    std::size_t cap_triangles = 0;  ///< triangles of the caps (clip_mesh_to_box: those left in the result,
                                    ///< the triangles on the box's faces)
    std::size_t cut_edges = 0;      ///< edges cut (one new vertex each)
    std::size_t merged = 0;         ///< cut vertices merged into a neighbour closer than the snap distance
    std::size_t flipped = 0;        ///< flat or turned-over triangles at the box edges removed by an edge flip
    std::size_t snapped = 0;        ///< vertices moved away from a plane (see clip_mesh_to_half_space)
    std::size_t forced = 0;         ///< cap triangles cut without a valid ear (crossing input only)
};

/// Keeps the part of `mesh` with side * (p[axis] - value) <= 0 (side +1: below the plane, -1:
/// above) and caps it. Vertices within `snap` (> 0) outside the plane to 2 snap inside it are first
/// moved along the axis into [2 snap, snap] inside it (order kept), so that no vertex lies on the
/// plane and no cut vertex comes nearer than `snap` to a vertex of its edge (no needle triangles,
/// no coincident points in the cap).
/// New vertices: vertex_level the lower of the edge's two ends; normals (if any) interpolated and
/// renormalised, attributes interpolated linearly. Pieces of cut triangles keep their kind; cap
/// triangles are TriangleKind::Patch. Consecutive cut vertices of a loop closer than `snap` are merged
/// (the boundary edge between them collapsed), so that no triangle collapses when rounded to float.
/// A mesh entirely outside becomes empty. Deterministic.
/// `faces`, when given, holds the planes of earlier cuts (a box's faces): a merged vertex whose run
/// met one of them lies on it afterwards.
ClipCounts clip_mesh_to_half_space(Mesh& mesh, int axis, float value, int side, double snap, const Box* faces = nullptr);

/// Clips by the box's six faces (x max, x min, y max, y min, z max, z min); `particle_radius` sets
/// the snap distance: 1e-3 r, or 2 float steps at the plane's coordinate if larger. Every vertex
/// of the result lies in the box. Triangles left flat (zero area in float) on the box's edges are
/// then removed by edge flips. `box` must be valid (finite, min < max).
ClipCounts clip_mesh_to_box(Mesh& mesh, const Box& box, float particle_radius);

}  // namespace trilevel
