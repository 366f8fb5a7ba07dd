// Connected components of a mesh by vertex index, and the removal of small ones (stray blobs of a
// few stuck or lost particles).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel {

/// The component of every triangle: components numbered 0, 1, ... in the order of their first
/// triangle; two triangles are in one component when a chain of shared vertex indices joins them.
std::vector<std::uint32_t> triangle_components(const Mesh& mesh, std::size_t* count = nullptr);

/// Volume each component of `triangle_components` encloses (mesh_topology.hpp's component_volumes:
/// positive for an outward-oriented closed surface, negative for a cavity's surface).
std::vector<double> component_volumes(const Mesh& mesh, const std::vector<std::uint32_t>& component, std::size_t count);

/// Removes the components whose |volume| is below `min_volume`; the vertices are compacted (their
/// order kept) and the triangles' indices remapped, vertex_level, triangle_kind, normals and
/// attributes follow. Returns how many components were removed. A closed mesh stays closed.
std::size_t remove_small_components(Mesh& mesh, double min_volume);

}  // namespace trilevel
