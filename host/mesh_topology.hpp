// Index topology of a triangle mesh (docs/design.md §7: closed, consistently oriented, no welding).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel {

/// Counts over undirected edges {a, b}, with n_ab / n_ba the uses of a->b / b->a.
struct MeshTopologyReport {
    std::size_t edges = 0;                   ///< distinct undirected edges
    std::size_t boundary_edges = 0;          ///< n_ab + n_ba == 1
    std::size_t orientation_conflicts = 0;   ///< two uses, same direction
    std::size_t non_manifold_edges = 0;      ///< more than two uses
    std::size_t degenerate_triangles = 0;    ///< a repeated vertex index
    std::size_t bad_indices = 0;             ///< indices >= vertex_count()
    bool closed_and_oriented() const {
        return boundary_edges == 0 && orientation_conflicts == 0 && non_manifold_edges == 0 &&
               degenerate_triangles == 0 && bad_indices == 0;
    }
};

/// Builds the report with a per-vertex list of outgoing edges (linear memory, parallel).
MeshTopologyReport mesh_topology_report(const Mesh& mesh);

/// Connected components of the mesh by shared vertices: `of_vertex[v]` in [0, count), numbered in
/// the order of each component's smallest vertex index (a vertex in no triangle is one of its own).
struct MeshComponents {
    std::vector<std::uint32_t> of_vertex;
    std::size_t count = 0;
};
MeshComponents mesh_components(const Mesh& mesh);

/// Volume each component encloses by the divergence theorem (double): positive for an
/// outward-oriented closed surface, negative for an inner one (a cavity's surface).
std::vector<double> component_volumes(const Mesh& mesh, const MeshComponents& components);

/// V - E + F of each component (E: distinct undirected edges); 2 for a sphere, 0 for a torus.
std::vector<long long> euler_characteristics(const Mesh& mesh, const MeshComponents& components);

}  // namespace trilevel
