// Edge collapse by index; see edge_collapse.hpp.
#include "edge_collapse.hpp"

#include <algorithm>
#include <cmath>

namespace trilevel {

namespace {

glm::dvec3 corner_min(const glm::dvec3 (&p)[3]) { return glm::min(p[0], glm::min(p[1], p[2])); }
glm::dvec3 corner_max(const glm::dvec3 (&p)[3]) { return glm::max(p[0], glm::max(p[1], p[2])); }
double extent(const glm::dvec3 (&p)[3]) {
    const glm::dvec3 d = corner_max(p) - corner_min(p);
    return std::max(d.x, std::max(d.y, d.z));
}

int orient(glm::dvec3 a, glm::dvec3 b, glm::dvec3 c, glm::dvec3 d) {
    const double o = glm::dot(glm::cross(b - a, c - a), d - a);
    return (o > 0.0) - (o < 0.0);
}

// Does segment pq pass through the inside of triangle abc (p and q strictly on either side, the
// line strictly inside all three edges)? Touching and coplanar contacts do not count.
bool segment_crosses(glm::dvec3 p, glm::dvec3 q, const glm::dvec3 (&t)[3]) {
    const int sp = orient(t[0], t[1], t[2], p), sq = orient(t[0], t[1], t[2], q);
    if (sp == 0 || sq == 0 || sp == sq) return false;
    const int s0 = orient(p, q, t[0], t[1]), s1 = orient(p, q, t[1], t[2]), s2 = orient(p, q, t[2], t[0]);
    return s0 != 0 && s0 == s1 && s1 == s2;
}

// Do two triangles cross (an edge of one through the inside of the other)?
bool triangles_cross(const glm::dvec3 (&a)[3], const glm::dvec3 (&b)[3]) {
    for (int k = 0; k < 3; ++k)
        if (segment_crosses(a[k], a[(k + 1) % 3], b) || segment_crosses(b[k], b[(k + 1) % 3], a)) return true;
    return false;
}

std::uint64_t cell_hash(std::int64_t x, std::int64_t y, std::int64_t z) {
    std::uint64_t h = std::uint64_t(x) * 0x9E3779B97F4A7C15ull ^ std::uint64_t(y) * 0xC2B2AE3D27D4EB4Full ^
                      std::uint64_t(z) * 0x165667B19E3779F9ull;
    return h ^ (h >> 29);
}

}  // namespace

EdgeCollapser::EdgeCollapser(Mesh& mesh, const std::vector<std::uint32_t>& vertices)
    : m_(mesh), list_(mesh.vertex_count(), -1), dead_tri_(mesh.triangle_count(), 0), dead_vertex_(mesh.vertex_count(), 0) {
    for (std::uint32_t v : vertices)
        if (list_[v] < 0) {
            list_[v] = std::int32_t(tris_.size());
            tris_.emplace_back();
        }
    for (std::uint32_t t = 0; t < mesh.triangle_count(); ++t)
        for (int k = 0; k < 3; ++k)
            if (const std::int32_t l = list_[mesh.triangles[3 * std::size_t(t) + k]]; l >= 0) tris_[l].push_back(t);
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

std::array<std::int64_t, 3> EdgeCollapser::cell(glm::dvec3 p) const {
    const glm::dvec3 c = glm::floor((p - origin_) / h_);
    return {std::int64_t(c.x), std::int64_t(c.y), std::int64_t(c.z)};
}

// Counting sort of the alive triangles into hashed buckets by their low corner's cell (cells that
// share a bucket only cost extra tests).
void EdgeCollapser::build_index() {
    indexed_ = true;
    const std::uint32_t nt = std::uint32_t(m_.triangle_count());
    moved_tri_.assign(nt, 0);
    glm::dvec3 lo(0.0);
    double h = 0.0;
    bool first = true;
    for (std::uint32_t t = 0; t < nt; ++t) {
        if (dead_tri_[t]) continue;
        const std::uint32_t* c = corners(t);
        const glm::dvec3 p[3] = {position(c[0]), position(c[1]), position(c[2])};
        lo = first ? corner_min(p) : glm::min(lo, corner_min(p));
        h = std::max(h, extent(p));
        first = false;
    }
    origin_ = lo;
    h_ = h > 0.0 && std::isfinite(h) ? h : 1.0;
    std::uint64_t buckets = 1;
    while (buckets < std::max<std::uint64_t>(nt / 2, 1)) buckets *= 2;
    bucket_mask_ = buckets - 1;
    std::vector<std::uint32_t> bucket(nt);
    bucket_start_.assign(buckets + 1, 0);
    for (std::uint32_t t = 0; t < nt; ++t) {
        if (dead_tri_[t]) continue;
        const std::uint32_t* c = corners(t);
        const glm::dvec3 p[3] = {position(c[0]), position(c[1]), position(c[2])};
        const auto k = cell(corner_min(p));
        bucket[t] = std::uint32_t(cell_hash(k[0], k[1], k[2]) & bucket_mask_);
        ++bucket_start_[bucket[t] + 1];
    }
    for (std::uint64_t b = 0; b < buckets; ++b) bucket_start_[b + 1] += bucket_start_[b];
    bucket_tris_.resize(bucket_start_[buckets]);
    std::vector<std::uint32_t> fill(bucket_start_.begin(), bucket_start_.end() - 1);
    for (std::uint32_t t = 0; t < nt; ++t)
        if (!dead_tri_[t]) bucket_tris_[fill[bucket[t]]++] = t;
    // A listed triangle keeps its corners until it moves (then it is listed in moved_buckets_), and
    // positions never change, so its box stays true; floats hold the float positions' bounds exactly.
    moved_buckets_.assign(buckets, {});
    bucket_lo_.resize(bucket_tris_.size());
    bucket_hi_.resize(bucket_tris_.size());
    for (std::size_t i = 0; i < bucket_tris_.size(); ++i) {
        const std::uint32_t* c = corners(bucket_tris_[i]);
        const glm::dvec3 p[3] = {position(c[0]), position(c[1]), position(c[2])};
        bucket_lo_[i] = glm::vec3(corner_min(p));
        bucket_hi_[i] = glm::vec3(corner_max(p));
    }
}

bool EdgeCollapser::makes_crossing(std::uint32_t v, std::uint32_t a, const std::vector<std::uint32_t>& moved) {
    if (!indexed_) build_index();
    // The moved triangles before and after, and the box around them all after the move.
    moved_geometry_.resize(moved.size());
    glm::dvec3 lo(0.0), hi(0.0);
    for (std::size_t i = 0; i < moved.size(); ++i) {
        auto& m = moved_geometry_[i];
        const std::uint32_t* c = corners(moved[i]);
        for (int k = 0; k < 3; ++k) {
            m.after[k] = c[k] == v ? a : c[k];
            m.p[k] = position(c[k]);
            m.q[k] = position(m.after[k]);
        }
        m.lo = corner_min(m.q);
        m.hi = corner_max(m.q);
        lo = i ? glm::min(lo, m.lo) : m.lo;
        hi = i ? glm::max(hi, m.hi) : m.hi;
    }
    // Every triangle that can reach the box: its low corner lies within its extent below lo, so
    // in the cells from cell(lo - extent) to cell(hi).
    near_.clear();
    auto gather = [&](double reach, auto&& visit) {
        const auto c0 = cell(lo - reach), c1 = cell(hi);
        for (std::int64_t z = c0[2]; z <= c1[2]; ++z)
            for (std::int64_t y = c0[1]; y <= c1[1]; ++y)
                for (std::int64_t x = c0[0]; x <= c1[0]; ++x) visit(cell_hash(x, y, z));
    };
    gather(h_, [&](std::uint64_t key) {
        const std::uint64_t b = key & bucket_mask_;
        for (std::uint32_t i = bucket_start_[b]; i < bucket_start_[b + 1]; ++i) {
            if (glm::any(glm::lessThan(glm::dvec3(bucket_hi_[i]), lo)) || glm::any(glm::greaterThan(glm::dvec3(bucket_lo_[i]), hi))) continue;
            if (!moved_tri_[bucket_tris_[i]]) near_.push_back(bucket_tris_[i]);
        }
    });
    if (any_moved_)
        gather(moved_extent_, [&](std::uint64_t key) {
            const auto& listed = moved_buckets_[key & bucket_mask_];
            near_.insert(near_.end(), listed.begin(), listed.end());
        });
    for (std::uint32_t u : near_) {
        if (dead_tri_[u]) continue;
        const std::uint32_t* b = corners(u);
        if (b[0] == v || b[1] == v || b[2] == v) continue;  // v's own triangles: they vanish or move too
        const glm::dvec3 r[3] = {position(b[0]), position(b[1]), position(b[2])};
        const glm::dvec3 rlo = corner_min(r), rhi = corner_max(r);
        if (glm::any(glm::lessThan(rhi, lo)) || glm::any(glm::greaterThan(rlo, hi))) continue;
        for (const auto& m : moved_geometry_) {
            if (glm::any(glm::lessThan(rhi, m.lo)) || glm::any(glm::greaterThan(rlo, m.hi))) continue;
            bool shared = false;
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j) shared |= b[i] == m.after[j];
            if (!shared && triangles_cross(m.q, r) && !triangles_cross(m.p, r)) return true;
        }
    }
    return false;
}

bool EdgeCollapser::collapse(std::uint32_t v, std::uint32_t a) {
    auto& tv = alive_triangles(v);
    auto& ta = alive_triangles(a);
    // v's triangles: the two on edge (v, a), which vanish, and the rest, which take a.
    auto &edge = edge_, &rest = rest_, &nv = nv_, &na = na_;
    edge.clear();
    rest.clear();
    nv.clear();
    na.clear();
    for (std::uint32_t t : tv) {
        const std::uint32_t* c = corners(t);
        (c[0] == a || c[1] == a || c[2] == a ? edge : rest).push_back(t);
    }
    if (edge.size() != 2) return false;
    std::uint32_t apex[2];
    for (int e = 0; e < 2; ++e) {
        const std::uint32_t* c = corners(edge[e]);
        apex[e] = c[0] != v && c[0] != a ? c[0] : c[1] != v && c[1] != a ? c[1] : c[2];
    }
    if (apex[0] == apex[1]) return false;
    // Link condition: v and a may share no neighbour but the two apexes, else the merged vertex
    // would carry a non-manifold edge. Neighbour lists here hold a dozen vertices.
    for (auto [ts, n] : {std::pair{&tv, &nv}, std::pair{&ta, &na}}) {
        for (std::uint32_t t : *ts) n->insert(n->end(), corners(t), corners(t) + 3);
        std::sort(n->begin(), n->end());
        n->erase(std::unique(n->begin(), n->end()), n->end());
    }
    if (nv.size() == 4 && na.size() == 4) return false;  // a tetrahedron would fold shut
    for (std::uint32_t x : nv)
        if (x != v && x != a && x != apex[0] && x != apex[1] && std::binary_search(na.begin(), na.end(), x))
            return false;
    const glm::dvec3 to = position(a);
    for (std::uint32_t t : rest)
        if (flips(t, v, to)) return false;
    if (makes_crossing(v, a, rest)) return false;
    for (std::uint32_t t : edge) dead_tri_[t] = 1;
    for (std::uint32_t t : rest) {
        std::uint32_t* c = corners(t);
        for (int k = 0; k < 3; ++k)
            if (c[k] == v) c[k] = a;
        ta.push_back(t);
        // Listed again by its new low corner (an entry left in another cell only costs a test).
        const glm::dvec3 p[3] = {position(c[0]), position(c[1]), position(c[2])};
        const auto k = cell(corner_min(p));
        moved_buckets_[cell_hash(k[0], k[1], k[2]) & bucket_mask_].push_back(t);
        any_moved_ = true;
        moved_tri_[t] = 1;
        moved_extent_ = std::max(moved_extent_, extent(p));
    }
    tv.clear();
    dead_vertex_[v] = 1;
    return true;
}

void EdgeCollapser::compact() {
    std::vector<std::uint32_t> id(m_.vertex_count());
    std::uint32_t n = 0;
    for (std::uint32_t v = 0; v < m_.vertex_count(); ++v) {
        id[v] = n;
        if (dead_vertex_[v]) continue;
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
}

}  // namespace trilevel
