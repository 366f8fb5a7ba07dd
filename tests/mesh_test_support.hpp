// Helpers of the [mesh] tests: fields on blocks of coarse cells, closed-mesh checks.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <unordered_map>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "core/coarse_cells.hpp"
#include "core/fine_point_map.hpp"
#include "mesh_topology.hpp"
#include "trilevel/trilevel.hpp"

#include <glm/glm.hpp>

namespace trilevel::test {

/// Cells of a dims^3 block at `offset` (coarse coordinates), sorted by lattice::pack, all `level`.
inline std::vector<CoarseCell> block_cells(glm::ivec3 dims, glm::ivec3 offset, std::uint8_t level) {
    std::vector<CoarseCell> cells;
    for (int z = 0; z < dims.z; ++z)
        for (int y = 0; y < dims.y; ++y)
            for (int x = 0; x < dims.x; ++x) cells.push_back({offset + glm::ivec3(x, y, z), level});
    return cells;  // x fastest: increasing pack order
}

/// A map holding every point of every cell at its stride, valued by `f(p)`.
inline FinePointMap make_field(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                               const std::function<float(glm::ivec3)>& f) {
    const int cs = frame.coarse_steps;
    const std::size_t per_cell = std::size_t(cs + 1) * (cs + 1) * (cs + 1);
    FinePointMap map(2 * per_cell * cells.size());
    for (const CoarseCell& c : cells) {
        const int st = stride(c.level);
        for (int z = 0; z <= cs; z += st)
            for (int y = 0; y <= cs; y += st)
                for (int x = 0; x <= cs; x += st) {
                    const glm::ivec3 p = c.coord * cs + glm::ivec3(x, y, z);
                    if (!map.find(p)) map.insert(lattice::pack(p), f(p));
                }
    }
    return map;
}

/// Does p lie on the boundary of the box of lattice points [lo, hi]?
inline bool on_box_boundary(glm::ivec3 p, glm::ivec3 lo, glm::ivec3 hi) {
    return glm::any(glm::equal(p, lo)) || glm::any(glm::equal(p, hi));
}

inline double signed_volume(const Mesh& m) {
    double v = 0.0;
    for (std::size_t t = 0; t < m.triangle_count(); ++t) {
        const float* a = &m.positions[3 * m.triangles[3 * t]];
        const float* b = &m.positions[3 * m.triangles[3 * t + 1]];
        const float* c = &m.positions[3 * m.triangles[3 * t + 2]];
        v += (double(a[0]) * (double(b[1]) * c[2] - double(b[2]) * c[1]) -
              double(a[1]) * (double(b[0]) * c[2] - double(b[2]) * c[0]) +
              double(a[2]) * (double(b[0]) * c[1] - double(b[1]) * c[0])) / 6.0;
    }
    return v;
}

/// A non-empty mesh, closed and consistently oriented, counter-clockwise seen from outside.
inline void require_closed(const Mesh& m, const std::string& what) {
    INFO(what << ": " << m.triangle_count() << " triangles");
    REQUIRE(m.triangle_count() > 0);
    const MeshTopologyReport t = mesh_topology_report(m);
    CHECK(t.boundary_edges == 0);
    CHECK(t.non_manifold_edges == 0);
    CHECK(t.orientation_conflicts == 0);
    REQUIRE(is_closed_and_oriented(m));
    REQUIRE(signed_volume(m) > 0);  // oriented outwards
}


struct PatchFolds {
    std::size_t flipped = 0;     ///< turned against the majority of their simple crack polygon
    std::size_t flat = 0;        ///< of zero area in their plane
    std::size_t non_simple = 0;  ///< crack polygons whose own edges cross: no triangulation lies flat
};

/// Patch triangles whose orientation in their transition-face plane disagrees with the rest of
/// their crack polygon (a folded or flipped fan), and those of zero area there. A crack polygon is
/// triangulated in one plane; its triangles are the patch triangles of that plane joined by shared
/// edges (polygons share no vertex), and a proper triangulation turns every one of them the same way.
inline PatchFolds patch_folds(const Mesh& m) {
    const std::size_t nt = m.triangle_count();
    auto pos = [&](std::uint32_t i) { return glm::dvec3(m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]); };
    std::vector<int> axis(nt, -1);
    std::vector<double> area(nt, 0.0);
    for (std::size_t t = 0; t < nt; ++t) {
        if (m.triangle_kind[t] != TriangleKind::Patch) continue;
        const glm::dvec3 a = pos(m.triangles[3 * t]), b = pos(m.triangles[3 * t + 1]), c = pos(m.triangles[3 * t + 2]);
        for (int k = 0; k < 3; ++k)
            if (a[k] == b[k] && a[k] == c[k]) axis[t] = k;
        if (axis[t] < 0) continue;
        const int u = (axis[t] + 1) % 3, v = (axis[t] + 2) % 3;
        area[t] = (b[u] - a[u]) * (c[v] - a[v]) - (b[v] - a[v]) * (c[u] - a[u]);
    }
    // Union of in-plane patch triangles across shared undirected edges.
    std::vector<std::size_t> parent(nt);
    for (std::size_t t = 0; t < nt; ++t) parent[t] = t;
    auto find = [&](std::size_t t) {
        while (parent[t] != t) t = parent[t] = parent[parent[t]];
        return t;
    };
    std::unordered_map<std::uint64_t, std::size_t> edge_owner;
    for (std::size_t t = 0; t < nt; ++t) {
        if (axis[t] < 0) continue;
        for (int k = 0; k < 3; ++k) {
            std::uint64_t a = m.triangles[3 * t + k], b = m.triangles[3 * t + (k + 1) % 3];
            if (a > b) std::swap(a, b);
            auto [it, fresh] = edge_owner.emplace((a << 32) | b, t);
            if (!fresh && axis[it->second] == axis[t]) parent[find(it->second)] = find(t);
        }
    }
    std::unordered_map<std::size_t, std::array<std::size_t, 2>> turns;  // per polygon: positive, negative
    PatchFolds out;
    for (std::size_t t = 0; t < nt; ++t) {
        if (axis[t] < 0) continue;
        if (area[t] == 0.0) ++out.flat;
        else ++turns[find(t)][area[t] > 0.0 ? 0 : 1];
    }
    // A polygon's outline: the edges of its triangles used once within it. Where two of them cross
    // (in the plane, properly) the polygon is not simple and folds whatever the triangulation.
    std::unordered_map<std::size_t, std::vector<std::array<std::uint32_t, 2>>> outline;
    {
        std::unordered_map<std::uint64_t, std::pair<std::size_t, int>> uses;  // edge -> polygon, count
        for (std::size_t t = 0; t < nt; ++t) {
            if (axis[t] < 0) continue;
            for (int k = 0; k < 3; ++k) {
                std::uint64_t a = m.triangles[3 * t + k], b = m.triangles[3 * t + (k + 1) % 3];
                if (a > b) std::swap(a, b);
                auto& u = uses[(a << 32) | b];
                u.first = find(t);
                ++u.second;
            }
        }
        for (const auto& [e, u] : uses)
            if (u.second == 1) outline[u.first].push_back({std::uint32_t(e >> 32), std::uint32_t(e & 0xffffffffu)});
    }
    auto orient2 = [](glm::dvec2 a, glm::dvec2 b, glm::dvec2 c) {
        const double o = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        return (o > 0.0) - (o < 0.0);
    };
    for (const auto& [root, n] : turns) {
        if (!n[0] || !n[1]) continue;
        const int ax = axis[root], u = (ax + 1) % 3, v = (ax + 2) % 3;
        auto pt = [&](std::uint32_t i) { const glm::dvec3 p = pos(i); return glm::dvec2(p[u], p[v]); };
        const auto& edges = outline[root];
        bool simple = true;
        for (std::size_t i = 0; i < edges.size() && simple; ++i)
            for (std::size_t j = i + 1; j < edges.size() && simple; ++j) {
                const auto [a, b] = edges[i];
                const auto [c, d] = edges[j];
                if (a == c || a == d || b == c || b == d) continue;
                const int s1 = orient2(pt(a), pt(b), pt(c)), s2 = orient2(pt(a), pt(b), pt(d));
                const int s3 = orient2(pt(c), pt(d), pt(a)), s4 = orient2(pt(c), pt(d), pt(b));
                if (s1 * s2 < 0 && s3 * s4 < 0) simple = false;
            }
        if (simple) out.flipped += std::min(n[0], n[1]);
        else ++out.non_simple;
    }
    return out;
}

/// Pairs of triangles that share no vertex index and cross properly: an edge of one passes through
/// the inside of the other (exact sign tests in double of float coordinates; touching and coplanar
/// contacts are not counted). `stride` > 1 tests every stride-th triangle against all others.
inline std::size_t self_intersections(const Mesh& m, std::size_t stride = 1) {
    const std::size_t nt = m.triangle_count();
    if (nt == 0) return 0;
    auto pos = [&](std::uint32_t i) { return glm::dvec3(m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]); };
    auto orient = [](glm::dvec3 a, glm::dvec3 b, glm::dvec3 c, glm::dvec3 d) {
        const double o = glm::dot(glm::cross(b - a, c - a), d - a);
        return (o > 0.0) - (o < 0.0);
    };
    // Does segment pq pass through the inside of triangle abc?
    auto crosses = [&](glm::dvec3 p, glm::dvec3 q, glm::dvec3 a, glm::dvec3 b, glm::dvec3 c) {
        const int sp = orient(a, b, c, p), sq = orient(a, b, c, q);
        if (sp == 0 || sq == 0 || sp == sq) return false;
        const int s0 = orient(p, q, a, b), s1 = orient(p, q, b, c), s2 = orient(p, q, c, a);
        return s0 != 0 && s0 == s1 && s1 == s2;
    };
    glm::dvec3 lo(1e300), hi(-1e300);
    for (std::size_t i = 0; i < m.positions.size() / 3; ++i) lo = glm::min(lo, pos(std::uint32_t(i))), hi = glm::max(hi, pos(std::uint32_t(i)));
    double longest = 0.0;
    for (std::size_t t = 0; t < nt; ++t)
        for (int k = 0; k < 3; ++k)
            longest = std::max(longest, glm::length(pos(m.triangles[3 * t + k]) - pos(m.triangles[3 * t + (k + 1) % 3])));
    const double cell = std::max(longest, 1e-30);
    auto cell_of = [&](glm::dvec3 p) { return glm::ivec3(glm::floor((p - lo) / cell)); };
    auto key = [](glm::ivec3 c) { return (std::uint64_t(c.x) << 42) ^ (std::uint64_t(c.y) << 21) ^ std::uint64_t(c.z); };
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;  // triangles by the cell of their first vertex
    for (std::size_t t = 0; t < nt; ++t) grid[key(cell_of(pos(m.triangles[3 * t])))].push_back(std::uint32_t(t));
    std::size_t hits = 0;
    for (std::size_t t = 0; t < nt; t += stride) {
        const std::uint32_t* a = &m.triangles[3 * t];
        const glm::dvec3 A[3] = {pos(a[0]), pos(a[1]), pos(a[2])};
        const glm::ivec3 c = cell_of(A[0]);
        for (int dz = -2; dz <= 2; ++dz)
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx) {
                    auto it = grid.find(key(c + glm::ivec3(dx, dy, dz)));
                    if (it == grid.end()) continue;
                    for (std::uint32_t u : it->second) {
                        if (u == t || (stride == 1 && u < t)) continue;
                        const std::uint32_t* b = &m.triangles[3 * std::size_t(u)];
                        bool shared = false;
                        for (int i = 0; i < 3; ++i)
                            for (int j = 0; j < 3; ++j) shared |= a[i] == b[j];
                        if (shared) continue;
                        const glm::dvec3 B[3] = {pos(b[0]), pos(b[1]), pos(b[2])};
                        bool x = false;
                        for (int k = 0; k < 3 && !x; ++k)
                            x = crosses(A[k], A[(k + 1) % 3], B[0], B[1], B[2]) || crosses(B[k], B[(k + 1) % 3], A[0], A[1], A[2]);
                        hits += x;
                    }
                }
    }
    return hits;
}

}  // namespace trilevel::test
