// Sliver cleanup; see sliver_cleanup.hpp.
#include "sliver_cleanup.hpp"

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include <glm/glm.hpp>
#include <tbb/parallel_for.h>

#include "edge_collapse.hpp"

namespace trilevel {

std::size_t collapse_slivers(Mesh& mesh, std::vector<std::uint32_t>* kept) {
    // The short edges, as (lower, higher) vertex pairs, in the order of their first triangle.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
    const auto& t = mesh.triangles;
    auto at = [&](std::uint32_t v) {
        return glm::dvec3(mesh.positions[3 * std::size_t(v)], mesh.positions[3 * std::size_t(v) + 1], mesh.positions[3 * std::size_t(v) + 2]);
    };
    constexpr std::uint32_t kNone = ~0u;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> short_edge(mesh.triangle_count(), {kNone, kNone});  // per triangle
    tbb::parallel_for(std::size_t(0), mesh.triangle_count(), [&](std::size_t f) {
        const std::size_t i = 3 * f;
        double len[3];
        for (int k = 0; k < 3; ++k) len[k] = glm::distance(at(t[i + k]), at(t[i + (k + 1) % 3]));
        const int s = len[0] <= len[1] && len[0] <= len[2] ? 0 : len[1] <= len[2] ? 1 : 2;
        if (!(len[s] < kSliverEdgeRatio * std::max({len[0], len[1], len[2]}))) return;
        const std::uint32_t a = t[i + s], b = t[i + (s + 1) % 3];
        short_edge[f] = {std::min(a, b), std::max(a, b)};
    });
    for (const auto& e : short_edge)
        if (e.first != kNone) edges.push_back(e);
    auto keep_all = [&] {
        if (kept) {
            kept->resize(mesh.vertex_count());
            for (std::uint32_t v = 0; v < kept->size(); ++v) (*kept)[v] = v;
        }
    };
    if (edges.empty()) {
        keep_all();
        return 0;
    }
    std::vector<std::uint32_t> vertices;
    vertices.reserve(2 * edges.size());
    for (auto [a, b] : edges) vertices.insert(vertices.end(), {a, b});
    EdgeCollapser c(mesh, vertices);
    std::size_t collapsed = 0;
    for (auto [a, b] : edges)  // an edge listed twice, or gone with an earlier collapse, is refused
        if (!c.dead(a) && !c.dead(b) && c.collapse(b, a)) ++collapsed;
    if (collapsed) {
        std::vector<std::uint32_t> left = c.compact();
        if (kept) *kept = std::move(left);
    } else {
        keep_all();
    }
    return collapsed;
}

}  // namespace trilevel
