// Components by vertex index and their removal; see mesh_components.hpp.
#include "mesh_components.hpp"

#include "mesh_topology.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace trilevel {

std::vector<std::uint32_t> triangle_components(const Mesh& mesh, std::size_t* count) {
    const MeshComponents c = mesh_components(mesh);  // numbered by smallest vertex
    constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
    std::vector<std::uint32_t> label(c.count, kNone), component(mesh.triangle_count());
    std::uint32_t next = 0;  // renumbered in the order of their first triangle; no triangle, no component
    for (std::size_t t = 0; t < component.size(); ++t) {
        std::uint32_t& l = label[c.of_vertex[mesh.triangles[3 * t]]];
        if (l == kNone) l = next++;
        component[t] = l;
    }
    if (count) *count = next;
    return component;
}

std::vector<double> component_volumes(const Mesh& mesh, const std::vector<std::uint32_t>& component, std::size_t count) {
    const MeshComponents c = mesh_components(mesh);
    const std::vector<double> by_vertex = component_volumes(mesh, c);  // mesh_topology.hpp
    std::vector<double> volume(count, 0.0);
    for (std::size_t t = 0; t < component.size(); ++t) volume[component[t]] = by_vertex[c.of_vertex[mesh.triangles[3 * t]]];
    return volume;
}

std::size_t remove_small_components(Mesh& mesh, double min_volume) {
    const MeshComponents c = mesh_components(mesh);  // one labelling: by vertex, volumes alike
    const std::vector<double> volume = component_volumes(mesh, c);
    const std::size_t nv = mesh.vertex_count(), nt = mesh.triangle_count();
    std::vector<std::uint8_t> has_triangle(c.count), drop(c.count);
    for (std::size_t t = 0; t < nt; ++t) has_triangle[c.of_vertex[mesh.triangles[3 * t]]] = 1;
    std::size_t removed = 0;  // a vertex without triangles is no component (none in a reconstruction)
    for (std::size_t k = 0; k < c.count; ++k) removed += drop[k] = has_triangle[k] && std::fabs(volume[k]) < min_volume;
    if (removed == 0) return 0;

    constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
    std::vector<std::uint32_t> remap(nv, kNone);
    for (std::size_t t = 0; t < nt; ++t)
        if (!drop[c.of_vertex[mesh.triangles[3 * t]]])
            for (int k = 0; k < 3; ++k) remap[mesh.triangles[3 * t + k]] = 0;
    std::uint32_t next = 0;
    for (std::size_t v = 0; v < nv; ++v)
        if (remap[v] != kNone) remap[v] = next++;
    auto compact = [&](auto& values, std::size_t per) {  // per-vertex arrays, in place
        if (values.size() != per * nv) return;
        for (std::size_t v = 0; v < nv; ++v)
            if (remap[v] != kNone)
                for (std::size_t k = 0; k < per; ++k) values[per * remap[v] + k] = values[per * v + k];
        values.resize(per * next);
    };
    compact(mesh.positions, 3);
    compact(mesh.vertex_level, 1);
    compact(mesh.normals, 3);
    for (auto& a : mesh.attributes) compact(a.values, std::size_t(a.components));
    std::size_t kept = 0;
    const bool kinds = mesh.triangle_kind.size() == nt;
    for (std::size_t t = 0; t < nt; ++t) {
        if (drop[c.of_vertex[mesh.triangles[3 * t]]]) continue;
        for (int k = 0; k < 3; ++k) mesh.triangles[3 * kept + k] = remap[mesh.triangles[3 * t + k]];
        if (kinds) mesh.triangle_kind[kept] = mesh.triangle_kind[t];
        ++kept;
    }
    mesh.triangles.resize(3 * kept);
    if (kinds) mesh.triangle_kind.resize(kept);
    return removed;
}

}  // namespace trilevel
