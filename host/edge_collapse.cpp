// Edge collapse by index; see edge_collapse.hpp.
#include "edge_collapse.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/run_beside.hpp"

namespace trilevel {

namespace {

glm::dvec3 corner_min(const glm::dvec3 (&p)[3]) { return glm::min(p[0], glm::min(p[1], p[2])); }
glm::dvec3 corner_max(const glm::dvec3 (&p)[3]) { return glm::max(p[0], glm::max(p[1], p[2])); }

int sign(double o) { return (o > 0.0) - (o < 0.0); }

/// Twice the area vector of triangle t: its plane's normal, taken once per triangle.
glm::dvec3 normal_of(const glm::dvec3 (&t)[3]) { return glm::cross(t[1] - t[0], t[2] - t[0]); }

int orient(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c, glm::dvec3 d) { return sign(glm::dot(glm::cross(b - a, c - a), d - a)); }

// Does segment pq, whose ends lie on sides sp and sq of triangle t's plane, pass through the
// inside of t (p and q strictly on either side, the line strictly inside all three edges)?
// Touching and coplanar contacts do not count.
bool segment_crosses(glm::dvec3 p, glm::dvec3 q, int sp, int sq, const glm::dvec3 (&t)[3]) {
    if (sp == 0 || sq == 0 || sp == sq) return false;
    const int s0 = orient(p, q, t[0], t[1]), s1 = orient(p, q, t[1], t[2]), s2 = orient(p, q, t[2], t[0]);
    return s0 != 0 && s0 == s1 && s1 == s2;
}

// Do two triangles cross (an edge of one through the inside of the other)? na, nb: their
// normal_of(). Each corner's side of the other's plane is taken once; most pairs end there,
// every corner on one side.
bool triangles_cross(const glm::dvec3 (&a)[3], glm::dvec3 na, const glm::dvec3 (&b)[3], glm::dvec3 nb) {
    int sa[3], sb[3];
    for (int k = 0; k < 3; ++k) {
        sa[k] = sign(glm::dot(nb, a[k] - b[0]));
        sb[k] = sign(glm::dot(na, b[k] - a[0]));
    }
    for (int k = 0; k < 3; ++k) {
        const int l = (k + 1) % 3;
        if (segment_crosses(a[k], a[l], sa[k], sa[l], b) || segment_crosses(b[k], b[l], sb[k], sb[l], a)) return true;
    }
    return false;
}

}  // namespace

std::vector<std::uint32_t> every_vertex(std::size_t n) {
    std::vector<std::uint32_t> all(n);
    for (std::size_t v = 0; v < n; ++v) all[v] = std::uint32_t(v);
    return all;
}

EdgeCollapser::EdgeCollapser(Mesh& mesh, const std::vector<std::uint32_t>& vertices)
    : m_(mesh), list_(mesh.vertex_count(), -1), dead_tri_(mesh.triangle_count(), 0), dead_vertex_(mesh.vertex_count(), 0) {
    if (vertices.empty()) return;
    // The crossing check's index (which every collapse queries) is made beside the lists.
    run_beside([&] { grid_.emplace(m_, dead_tri_); }, [&] { list_triangles(vertices); });
}

void EdgeCollapser::list_triangles(const std::vector<std::uint32_t>& vertices) {
    for (std::uint32_t v : vertices)
        if (list_[v] < 0) {
            list_[v] = std::int32_t(tris_.size());
            tris_.emplace_back();
        }
    // On all threads: counted first, so that each list is allocated once (with room for the
    // triangles a few collapses bring), then filled at atomic cursors and sorted, which gives
    // the lists one thread would make.
    const std::size_t nt = m_.triangle_count();
    std::vector<std::atomic<std::uint32_t>> count(tris_.size());
    auto each_listed_corner = [&](auto&& f) {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nt, 16384), [&](const auto& range) {
            for (std::size_t t = range.begin(); t != range.end(); ++t)
                for (int k = 0; k < 3; ++k)
                    if (const std::int32_t l = list_[m_.triangles[3 * t + k]]; l >= 0) f(std::size_t(l), std::uint32_t(t));
        });
    };
    each_listed_corner([&](std::size_t l, std::uint32_t) { count[l].fetch_add(1, std::memory_order_relaxed); });
    tbb::parallel_for(std::size_t(0), tris_.size(), [&](std::size_t l) {
        const std::uint32_t n = count[l].load(std::memory_order_relaxed);
        tris_[l].reserve(n + 4);
        tris_[l].resize(n);
        count[l].store(0, std::memory_order_relaxed);
    });
    each_listed_corner([&](std::size_t l, std::uint32_t t) { tris_[l][count[l].fetch_add(1, std::memory_order_relaxed)] = t; });
    tbb::parallel_for(std::size_t(0), tris_.size(), [&](std::size_t l) { std::sort(tris_[l].begin(), tris_[l].end()); });
}

std::vector<std::uint32_t>& EdgeCollapser::alive_triangles(std::uint32_t v) {
    auto& ts = tris_[list_[v]];
    std::erase_if(ts, [&](std::uint32_t t) { return dead_tri_[t] != 0; });
    return ts;
}

// Would moving v to `to` turn triangle t over (or make it degenerate)?
bool EdgeCollapser::flips(std::uint32_t t, std::uint32_t v, glm::dvec3 to) {
    const std::uint32_t* c = corners(t);
    glm::dvec3 p[3], q[3];
    for (int k = 0; k < 3; ++k) p[k] = q[k] = position(c[k]);
    for (int k = 0; k < 3; ++k)
        if (c[k] == v) q[k] = to;
    const glm::dvec3 before = glm::cross(p[1] - p[0], p[2] - p[0]), after = glm::cross(q[1] - q[0], q[2] - q[0]);
    return glm::dot(before, after) <= 0.0;
}

void EdgeCollapser::prepare_parallel(double growth) {
    bound_ = growth * grid_->reach();
    grid_->widen_reach(bound_);
}

void EdgeCollapser::adopt(Worker& w) { grid_->adopt(w.relisted); }

bool EdgeCollapser::makes_crossing(std::uint32_t v, std::uint32_t a, const std::vector<std::uint32_t>& moved, Worker& w) {
    auto& moved_geometry = w.moved;
    auto& near = w.near;
    // The moved triangles before and after, and the box around them all after the move.
    moved_geometry.resize(moved.size());
    glm::dvec3 lo(0.0), hi(0.0);
    for (std::size_t i = 0; i < moved.size(); ++i) {
        auto& m = moved_geometry[i];
        const std::uint32_t* c = corners(moved[i]);
        for (int k = 0; k < 3; ++k) {
            m.after[k] = c[k] == v ? a : c[k];
            m.p[k] = position(c[k]);
            m.q[k] = position(m.after[k]);
        }
        m.lo = corner_min(m.q);
        m.hi = corner_max(m.q);
        m.np = normal_of(m.p);
        m.nq = normal_of(m.q);
        lo = i ? glm::min(lo, m.lo) : m.lo;
        hi = i ? glm::max(hi, m.hi) : m.hi;
    }
    near.clear();
    grid_->for_each_near(lo, hi, w.relisted, [&](std::uint32_t t) { near.push_back(t); });
    for (std::uint32_t u : near) {
        if (dead_tri_[u]) continue;
        const std::uint32_t* b = corners(u);
        if (b[0] == v || b[1] == v || b[2] == v) continue;  // v's own triangles: they vanish or move too
        const glm::dvec3 r[3] = {position(b[0]), position(b[1]), position(b[2])};
        const glm::dvec3 rlo = corner_min(r), rhi = corner_max(r);
        if (glm::any(glm::lessThan(rhi, lo)) || glm::any(glm::greaterThan(rlo, hi))) continue;
        const glm::dvec3 nr = normal_of(r);
        for (const auto& m : moved_geometry) {
            if (glm::any(glm::lessThan(rhi, m.lo)) || glm::any(glm::greaterThan(rlo, m.hi))) continue;
            bool shared = false;
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) shared |= b[i] == m.after[j];
            if (!shared && triangles_cross(m.q, m.nq, r, nr) && !triangles_cross(m.p, m.np, r, nr)) return true;
        }
    }
    return false;
}

EdgeCollapser::Outcome EdgeCollapser::collapse(std::uint32_t v, std::uint32_t a, Worker& w) {
    constexpr Outcome refused = Outcome::Refused;
    auto& tv = alive_triangles(v);
    auto& ta = alive_triangles(a);
    // v's triangles: the two on edge (v, a), which vanish, and the rest, which take a.
    auto &edge = w.edge, &rest = w.rest, &nv = w.nv, &na = w.na;
    edge.clear();
    rest.clear();
    nv.clear();
    na.clear();
    for (std::uint32_t t : tv) {
        const std::uint32_t* c = corners(t);
        (c[0] == a || c[1] == a || c[2] == a ? edge : rest).push_back(t);
    }
    if (edge.size() != 2) return refused;
    std::uint32_t apex[2];
    for (int e = 0; e < 2; ++e) {
        const std::uint32_t* c = corners(edge[e]);
        apex[e] = c[0] != v && c[0] != a ? c[0] : c[1] != v && c[1] != a ? c[1] : c[2];
    }
    if (apex[0] == apex[1]) return refused;
    // Link condition: v and a may share no neighbour but the two apexes, else the merged vertex
    // would carry a non-manifold edge. Neighbour lists here hold a dozen vertices.
    for (auto [ts, n] : {std::pair{&tv, &nv}, std::pair{&ta, &na}}) {
        for (std::uint32_t t : *ts) n->insert(n->end(), corners(t), corners(t) + 3);
        std::sort(n->begin(), n->end());
        n->erase(std::unique(n->begin(), n->end()), n->end());
    }
    if (nv.size() == 4 && na.size() == 4) return refused;  // a tetrahedron would fold shut
    for (std::uint32_t x : nv)
        if (x != v && x != a && x != apex[0] && x != apex[1] && std::binary_search(na.begin(), na.end(), x))
            return refused;
    const glm::dvec3 to = position(a);
    for (std::uint32_t t : rest)
        if (flips(t, v, to)) return refused;
    if (makes_crossing(v, a, rest, w)) return refused;
    if (w.parallel)  // a region's moved triangles stay within the bound the regions are apart by
        for (const MovedTriangle& m : w.moved) {
            const glm::dvec3 d = m.hi - m.lo;
            if (std::max(d.x, std::max(d.y, d.z)) > bound_) return Outcome::Deferred;
        }
    for (std::uint32_t t : edge) dead_tri_[t] = 1;
    for (std::uint32_t t : rest) {
        std::uint32_t* c = corners(t);
        for (int k = 0; k < 3; ++k)
            if (c[k] == v) c[k] = a;
        ta.push_back(t);
        const glm::dvec3 p[3] = {position(c[0]), position(c[1]), position(c[2])};
        grid_->relist(t, corner_min(p), corner_max(p), w.parallel ? &w.relisted : nullptr);
    }
    tv.clear();
    dead_vertex_[v] = 1;
    collapses_.fetch_add(1, std::memory_order_relaxed);
    return Outcome::Collapsed;
}

std::vector<std::uint32_t> EdgeCollapser::compact() {
    if (collapses_ == 0) return every_vertex(m_.vertex_count());
    std::vector<std::uint32_t> id(m_.vertex_count()), kept_vertices;
    std::uint32_t n = 0;
    for (std::uint32_t v = 0; v < m_.vertex_count(); ++v) {
        id[v] = n;
        if (dead_vertex_[v]) continue;
        kept_vertices.push_back(v);
        for (int k = 0; k < 3; ++k) m_.positions[3 * std::size_t(n) + k] = m_.positions[3 * std::size_t(v) + k];
        m_.vertex_level[n++] = m_.vertex_level[v];
    }
    m_.positions.resize(3 * std::size_t(n));
    m_.vertex_level.resize(n);
    std::size_t kept = 0;
    for (std::size_t t = 0; t < m_.triangle_count(); ++t) {
        if (dead_tri_[t]) continue;
        for (int k = 0; k < 3; ++k) m_.triangles[3 * kept + k] = id[m_.triangles[3 * t + k]];
        m_.triangle_kind[kept++] = m_.triangle_kind[t];
    }
    m_.triangles.resize(3 * kept);
    m_.triangle_kind.resize(kept);
    return kept_vertices;
}

}  // namespace trilevel
