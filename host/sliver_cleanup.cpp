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
    if (edges.empty()) {
        if (kept) *kept = every_vertex(mesh.vertex_count());
        return 0;
    }
    std::vector<std::uint32_t> vertices;
    vertices.reserve(2 * edges.size());
    for (auto [a, b] : edges) vertices.insert(vertices.end(), {a, b});
    EdgeCollapser c(mesh, vertices);
    // Moved triangles may grow to 1.5 times the largest now: on the x64 dam break none grows more
    // (at 1.0, a third of the collapses would wait for the serial pass).
    c.prepare_parallel(1.5);
    // Regions: tiles across the mesh's two longest axes, 6 interaction reaches wide, in four
    // phases (EdgeCollapser::in_tiles). A collapse reads within 3 and writes within 2 reaches of
    // its v (edge_collapse.hpp), so two tiles of one phase, a tile apart, never meet; the result
    // does not depend on the threads. In a tile, the edges in their order; an edge whose collapse
    // would grow a triangle beyond the bound waits for the serial pass at the end, in the edges'
    // order. Each edge's v is its higher end (merged into the lower), and places its edge.
    const std::vector<std::uint8_t> deferred = c.in_tiles(
        edges.size(), 6.0 * c.interaction_reach(), [&](std::uint32_t i) { return at(edges[i].second); },
        [&](std::uint32_t i, EdgeCollapser::Worker& w) {
            const auto [a, b] = edges[i];  // an edge listed twice, or gone with an earlier collapse, is refused
            return c.dead(a) || c.dead(b) || c.collapse(b, a, w) != EdgeCollapser::Outcome::Deferred;
        });
    for (std::uint32_t i = 0; i < edges.size(); ++i)
        if (deferred[i] && !c.dead(edges[i].first) && !c.dead(edges[i].second)) c.collapse(edges[i].second, edges[i].first);
    const std::size_t collapsed = c.collapses();
    std::vector<std::uint32_t> left = c.compact();
    if (kept) *kept = std::move(left);
    return collapsed;
}

}  // namespace trilevel
