// Components by vertex index and their removal; see mesh_components.hpp.
#include "mesh_components.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace trilevel {
namespace {

std::uint32_t find(std::vector<std::uint32_t>& parent, std::uint32_t v) {
    while (parent[v] != v) {
        parent[v] = parent[parent[v]];
        v = parent[v];
    }
    return v;
}

}  // namespace

std::vector<std::uint32_t> triangle_components(const Mesh& mesh, std::size_t* count) {
    const std::size_t nv = mesh.vertex_count(), nt = mesh.triangle_count();
    std::vector<std::uint32_t> parent(nv);
    std::iota(parent.begin(), parent.end(), 0u);
    for (std::size_t t = 0; t < nt; ++t) {
        const std::uint32_t* tri = &mesh.triangles[3 * t];
        for (int k = 1; k < 3; ++k) {
            const std::uint32_t a = find(parent, tri[0]), b = find(parent, tri[k]);
            if (a != b) parent[std::max(a, b)] = std::min(a, b);
        }
    }
    constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
    std::vector<std::uint32_t> label(nv, kNone), component(nt);
    std::uint32_t next = 0;
    for (std::size_t t = 0; t < nt; ++t) {
        const std::uint32_t root = find(parent, mesh.triangles[3 * t]);
        if (label[root] == kNone) label[root] = next++;
        component[t] = label[root];
    }
    if (count) *count = next;
    return component;
}

std::vector<double> component_volumes(const Mesh& mesh, const std::vector<std::uint32_t>& component, std::size_t count) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], double(mesh.positions[3 * v + k]));
            hi[k] = std::max(hi[k], double(mesh.positions[3 * v + k]));
        }
    double o[3];
    for (int k = 0; k < 3; ++k) o[k] = mesh.vertex_count() ? 0.5 * (lo[k] + hi[k]) : 0.0;
    std::vector<double> volume(count, 0.0);
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
        double p[3][3];
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k) p[i][k] = double(mesh.positions[3 * mesh.triangles[3 * t + i] + k]) - o[k];
        volume[component[t]] += (p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) -
                                 p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
                                 p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])) / 6.0;
    }
    return volume;
}

std::size_t remove_small_components(Mesh& mesh, double min_volume) {
    std::size_t count = 0;
    const std::vector<std::uint32_t> component = triangle_components(mesh, &count);
    const std::vector<double> volume = component_volumes(mesh, component, count);
    std::vector<std::uint8_t> drop(count);
    std::size_t removed = 0;
    for (std::size_t c = 0; c < count; ++c) removed += drop[c] = std::fabs(volume[c]) < min_volume;
    if (removed == 0) return 0;

    const std::size_t nv = mesh.vertex_count(), nt = mesh.triangle_count();
    constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
    std::vector<std::uint32_t> remap(nv, kNone);
    for (std::size_t t = 0; t < nt; ++t)
        if (!drop[component[t]])
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
        if (drop[component[t]]) continue;
        for (int k = 0; k < 3; ++k) mesh.triangles[3 * kept + k] = remap[mesh.triangles[3 * t + k]];
        if (kinds) mesh.triangle_kind[kept] = mesh.triangle_kind[t];
        ++kept;
    }
    mesh.triangles.resize(3 * kept);
    if (kinds) mesh.triangle_kind.resize(kept);
    return removed;
}

}  // namespace trilevel
