// Edge collapse by index; see edge_collapse.hpp.
#include "edge_collapse.hpp"

#include <algorithm>

namespace trilevel {

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
    for (std::uint32_t t : edge) dead_tri_[t] = 1;
    for (std::uint32_t t : rest) {
        std::uint32_t* c = corners(t);
        for (int k = 0; k < 3; ++k)
            if (c[k] == v) c[k] = a;
        ta.push_back(t);
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
