// Index-topology checks of a mesh (docs/design.md §7); see mesh_topology.hpp.
#include "mesh_topology.hpp"

#include <algorithm>
#include <atomic>
#include <limits>
#include <numeric>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>
#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include "core/union_find.hpp"

namespace trilevel {
namespace {

// Each vertex's fan, compressed-row: for every corner at vertex v, in [offset[v], offset[v+1]),
// the vertex after v in that triangle (edge v->next) and the one before it (edge prev->v).
struct Fans {
    std::vector<std::uint32_t> offset, next, prev;
    /// Uses of the directed edge a->b.
    std::size_t count(std::uint32_t a, std::uint32_t b) const {
        std::size_t n = 0;
        for (std::uint32_t i = offset[a]; i < offset[a + 1]; ++i) n += next[i] == b;
        return n;
    }
};

// For a mesh of whole triangles with valid indices.
Fans build_fans(const Mesh& mesh) {
    const std::size_t nv = mesh.vertex_count();
    const auto& t = mesh.triangles;
    Fans g;
    g.offset.assign(nv + 1, 0);
    for (std::uint32_t v : t) ++g.offset[v + 1];
    for (std::size_t v = 0; v < nv; ++v) g.offset[v + 1] += g.offset[v];
    std::vector<std::uint32_t> fill(g.offset.begin(), g.offset.end() - 1);
    g.next.resize(t.size());
    g.prev.resize(t.size());
    for (std::size_t i = 0; i < t.size(); i += 3)
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t at = fill[t[i + k]]++;
            g.next[at] = t[i + (k + 1) % 3];
            g.prev[at] = t[i + (k + 2) % 3];
        }
    return g;
}

// The report's first two counts: triangles with an index past the vertices (one more when the
// list is not whole triangles) and triangles that repeat a vertex.
void count_faulty_triangles(const Mesh& mesh, MeshTopologyReport& r) {
    const std::size_t nv = mesh.vertex_count();
    const auto& t = mesh.triangles;
    for (std::size_t i = 0; i + 2 < t.size(); i += 3) {
        if (t[i] >= nv || t[i + 1] >= nv || t[i + 2] >= nv) ++r.bad_indices;
        if (t[i] == t[i + 1] || t[i + 1] == t[i + 2] || t[i] == t[i + 2]) ++r.degenerate_triangles;
    }
    r.bad_indices += t.size() % 3 != 0;
}

}  // namespace

MeshTopologyReport mesh_topology_report(const Mesh& mesh) {
    MeshTopologyReport r;
    const std::size_t nv = mesh.vertex_count();
    count_faulty_triangles(mesh, r);
    if (r.bad_indices) return r;
    const Fans g = build_fans(mesh);
    tbb::combinable<MeshTopologyReport> part;
    // Each undirected edge is judged once: at the first listing of its smaller-to-larger use,
    // or, when there is none, at the first listing of its larger-to-smaller use.
    tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, std::uint32_t(nv), 4096), [&](const auto& range) {
        MeshTopologyReport& p = part.local();
        for (std::uint32_t a = range.begin(); a != range.end(); ++a)
            for (std::uint32_t i = g.offset[a]; i < g.offset[a + 1]; ++i) {
                const std::uint32_t b = g.next[i];
                if (b == a) continue;
                bool first = true;
                for (std::uint32_t j = g.offset[a]; j < i; ++j) first &= g.next[j] != b;
                if (!first) continue;
                const std::size_t nab = g.count(a, b), nba = g.count(b, a);
                if (a > b && nba > 0) continue;
                ++p.edges;
                if (nab + nba == 1) ++p.boundary_edges;
                else if (nab + nba > 2) ++p.non_manifold_edges;
                else if (nab != 1) ++p.orientation_conflicts;
            }
    });
    part.combine_each([&](const MeshTopologyReport& p) {
        r.edges += p.edges;
        r.boundary_edges += p.boundary_edges;
        r.orientation_conflicts += p.orientation_conflicts;
        r.non_manifold_edges += p.non_manifold_edges;
    });
    return r;
}

MeshComponents mesh_components(const Mesh& mesh) {
    const std::size_t nv = mesh.vertex_count();
    UnionFind sets(nv);  // the root stays the smallest vertex
    const auto& t = mesh.triangles;
    for (std::size_t i = 0; i + 2 < t.size(); i += 3)
        for (int k = 1; k < 3; ++k) sets.join(t[i], t[i + k]);
    MeshComponents c;
    c.of_vertex.resize(nv);
    for (std::uint32_t v = 0; v < nv; ++v) {
        const std::uint32_t r = sets.find(v);
        c.of_vertex[v] = r == v ? std::uint32_t(c.count++) : c.of_vertex[r];  // r <= v: numbered already
    }
    return c;
}

std::vector<double> component_volumes(const Mesh& mesh, const MeshComponents& components) {
    // det(a - o, b - o, c - o) / 6 summed over the component's triangles, o its first triangle's
    // first vertex: a small droplet far from the origin keeps its digits.
    std::vector<double> vol(components.count, 0.0);
    std::vector<std::uint32_t> origin(components.count, std::numeric_limits<std::uint32_t>::max());
    const auto& t = mesh.triangles;
    auto at = [&](std::uint32_t v) {
        return glm::dvec3(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
    };
    for (std::size_t i = 0; i + 2 < t.size(); i += 3) {
        const std::uint32_t c = components.of_vertex[t[i]];
        if (origin[c] == std::numeric_limits<std::uint32_t>::max()) origin[c] = t[i];
        const glm::dvec3 o = at(origin[c]);
        vol[c] += glm::dot(at(t[i]) - o, glm::cross(at(t[i + 1]) - o, at(t[i + 2]) - o)) / 6.0;
    }
    return vol;
}

std::vector<long long> euler_characteristics(const Mesh& mesh, const MeshComponents& components) {
    std::vector<long long> chi(components.count, 0);
    for (std::uint32_t v = 0; v < mesh.vertex_count(); ++v) ++chi[components.of_vertex[v]];
    const auto& t = mesh.triangles;
    std::vector<std::uint64_t> edges;
    edges.reserve(t.size());
    for (std::size_t i = 0; i + 2 < t.size(); i += 3) {
        ++chi[components.of_vertex[t[i]]];
        for (int k = 0; k < 3; ++k) {
            const std::uint64_t a = t[i + k], b = t[i + (k + 1) % 3];
            edges.push_back(std::min(a, b) << 32 | std::max(a, b));
        }
    }
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    for (std::uint64_t e : edges) --chi[components.of_vertex[std::uint32_t(e >> 32)]];
    return chi;
}

// Decided around each vertex a: with Next(a) the vertices that follow a in its triangles (edges
// a->b) and Prev(a) those that precede it (edges c->a), a mesh without bad indices or degenerate
// triangles is closed and consistently oriented exactly when, at every vertex, Next(a) holds no
// vertex twice and equals Prev(a) as a multiset: then each used edge a->b is used once, and so is
// b->a (b in Prev(a)), and no edge has a third use. Everything is read from a's own fan, where
// mesh_topology_report reads each neighbour's list too (a cache miss an edge).
bool is_closed_and_oriented(const Mesh& mesh) {
    MeshTopologyReport faults;
    count_faulty_triangles(mesh, faults);
    if (faults.bad_indices || faults.degenerate_triangles) return false;
    Fans g = build_fans(mesh);
    const std::size_t nv = mesh.vertex_count();
    std::atomic<bool> ok{true};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const auto& range) {
        for (std::size_t v = range.begin(); v != range.end() && ok.load(std::memory_order_relaxed); ++v) {
            // Sorted in place (a fan holds about six corners), then compared.
            std::uint32_t *n = g.next.data() + g.offset[v], *p = g.prev.data() + g.offset[v];
            const std::size_t d = g.offset[v + 1] - g.offset[v];
            std::sort(n, n + d);
            std::sort(p, p + d);
            if (!std::equal(n, n + d, p) || std::adjacent_find(n, n + d) != n + d) ok.store(false, std::memory_order_relaxed);
        }
    });
    return ok.load();
}

}  // namespace trilevel
