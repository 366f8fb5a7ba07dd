// Clipping by planes with flat caps; see mesh_clip.hpp.
#include "mesh_clip.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include <tbb/parallel_for.h>

#include "polygon_triangulation.hpp"

namespace trilevel {
namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

/// Appends a vertex's normal and attributes interpolated between `a` (t = 0) and `b` (t = 1).
void append_vertex_data(const Mesh& in, Mesh& out, std::uint32_t a, std::uint32_t b, double t) {
    if (!in.normals.empty()) {
        double n[3], len = 0.0;
        for (int k = 0; k < 3; ++k) {
            n[k] = in.normals[3 * a + k] + t * (double(in.normals[3 * b + k]) - in.normals[3 * a + k]);
            len += n[k] * n[k];
        }
        len = std::sqrt(len);
        for (int k = 0; k < 3; ++k) out.normals.push_back(len > 0 ? float(n[k] / len) : 0.0f);
    }
    for (std::size_t i = 0; i < in.attributes.size(); ++i) {
        const auto& src = in.attributes[i];
        const std::size_t c = std::size_t(src.components);
        for (std::size_t k = 0; k < c; ++k)
            out.attributes[i].values.push_back(
                float(src.values[c * a + k] + t * (double(src.values[c * b + k]) - src.values[c * a + k])));
    }
}

void copy_vertex_data(const Mesh& in, Mesh& out, std::uint32_t v) {
    if (!in.normals.empty()) out.normals.insert(out.normals.end(), &in.normals[3 * v], &in.normals[3 * v] + 3);
    for (std::size_t i = 0; i < in.attributes.size(); ++i) {
        const std::size_t c = std::size_t(in.attributes[i].components);
        const auto& src = in.attributes[i].values;
        out.attributes[i].values.insert(out.attributes[i].values.end(), src.begin() + std::ptrdiff_t(c * v),
                                        src.begin() + std::ptrdiff_t(c * v + c));
    }
}

double area2(const Mesh& m, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    double e[2][3];
    for (int k = 0; k < 3; ++k) {
        e[0][k] = double(m.positions[3 * b + k]) - m.positions[3 * a + k];
        e[1][k] = double(m.positions[3 * c + k]) - m.positions[3 * a + k];
    }
    const double x = e[0][1] * e[1][2] - e[0][2] * e[1][1], y = e[0][2] * e[1][0] - e[0][0] * e[1][2],
                 z = e[0][0] * e[1][1] - e[0][1] * e[1][0];
    return x * x + y * y + z * z;
}

double dist2_of(const Mesh& m, std::uint32_t a, std::uint32_t b) {
    double s = 0.0;
    for (int k = 0; k < 3; ++k) s += (double(m.positions[3 * a + k]) - m.positions[3 * b + k]) * (double(m.positions[3 * a + k]) - m.positions[3 * b + k]);
    return s;
}

/// The component of triangle (a, b, c)'s normal along the outward normal of face (axis, side).
double facing(const Mesh& m, std::uint32_t a, std::uint32_t b, std::uint32_t c, int axis, int side) {
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    const double bu = double(m.positions[3 * b + u]) - m.positions[3 * a + u], bw = double(m.positions[3 * b + w]) - m.positions[3 * a + w];
    const double cu = double(m.positions[3 * c + u]) - m.positions[3 * a + u], cw = double(m.positions[3 * c + w]) - m.positions[3 * a + w];
    return side * (bu * cw - bw * cu);
}

/// Triangles of zero area (three vertices on one line, in float), and slivers on a box face
/// turned over: where a box edge gathers the straight boundaries of two caps, a later cut, the
/// snap or a merge may put a vertex on that line or just across it. Each is removed by flipping
/// its longest edge (a, b) against the triangle across it, (b, a, d): the third vertex c then joins
/// d, giving (c, a, d) and (c, d, b), which replace (b, a, d) and the bad triangle when c lies on
/// or just inside (b, a, d) -- the flip is made only when both are sound (non-zero area, facing out
/// on a face). Only triangles with a vertex on the box's boundary can be bad this way, so only
/// those are indexed. Returns the flips.
std::size_t flip_bad_triangles(Mesh& m, const Box& box) {
    const std::size_t nv = m.vertex_count(), nt = m.triangle_count();
    std::vector<std::uint8_t> on(nv, 0);
    for (std::size_t v = 0; v < nv; ++v)
        for (int k = 0; k < 3; ++k) on[v] |= m.positions[3 * v + k] == box.min[k] || m.positions[3 * v + k] == box.max[k];
    std::vector<std::uint32_t> near;  // triangles with a vertex on the boundary, in order
    for (std::size_t t = 0; t < nt; ++t)
        if (on[m.triangles[3 * t]] || on[m.triangles[3 * t + 1]] || on[m.triangles[3 * t + 2]]) near.push_back(std::uint32_t(t));
    std::unordered_map<std::uint64_t, std::uint32_t> edge;  // directed edge -> triangle
    auto key = [](std::uint32_t u, std::uint32_t v) { return (std::uint64_t(u) << 32) | v; };
    auto index = [&](std::uint32_t t, bool add) {
        for (int k = 0; k < 3; ++k) {
            const std::uint64_t e = key(m.triangles[3 * t + k], m.triangles[3 * t + (k + 1) % 3]);
            if (add) edge[e] = t;
            else edge.erase(e);
        }
    };
    edge.reserve(3 * near.size());
    for (std::uint32_t t : near) index(t, true);
    // sound: non-zero area, and facing out when on a face
    auto sound = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        if (area2(m, a, b, c) == 0.0) return false;
        for (int k = 0; k < 3; ++k)
            for (int s : {1, -1}) {
                const float plane = s > 0 ? box.max[k] : box.min[k];
                if (m.positions[3 * a + k] == plane && m.positions[3 * b + k] == plane && m.positions[3 * c + k] == plane)
                    return facing(m, a, b, c, k, s) > 0.0;
            }
        return true;
    };
    std::size_t flips = 0;
    for (int pass = 0; pass < 64; ++pass) {  // a fan of bad triangles unfolds from its outer end, one a pass
        std::size_t flipped = 0;
        for (std::uint32_t t : near) {
            std::uint32_t* T = &m.triangles[3 * t];
            if (sound(T[0], T[1], T[2])) continue;
            // its edges from the longest: the first whose flip gives two sound triangles
            int order[3] = {0, 1, 2};
            std::sort(order, order + 3, [&](int i, int j) {
                const double li = dist2_of(m, T[i], T[(i + 1) % 3]), lj = dist2_of(m, T[j], T[(j + 1) % 3]);
                return li != lj ? li > lj : i < j;
            });
            for (int r : order) {
                const std::uint32_t a = T[r], b = T[(r + 1) % 3], c = T[(r + 2) % 3];
                if (dist2_of(m, c, a) == 0.0 || dist2_of(m, c, b) == 0.0) continue;  // coincident points
                const auto across = edge.find(key(b, a));
                if (across == edge.end()) continue;
                const std::uint32_t n = across->second;
                std::uint32_t* N = &m.triangles[3 * n];
                int q = 0;
                while (N[q] != b) ++q;
                const std::uint32_t d = N[(q + 2) % 3];
                if (d == c || edge.count(key(c, d)) || edge.count(key(d, c))) continue;
                if (!sound(c, a, d) || !sound(c, d, b)) continue;
                index(t, false);
                index(n, false);
                T[0] = c, T[1] = a, T[2] = d;
                N[0] = c, N[1] = d, N[2] = b;
                if (!m.triangle_kind.empty()) m.triangle_kind[t] = m.triangle_kind[n];  // both are halves of (b, a, d)
                index(t, true);
                index(n, true);
                ++flipped;
                break;
            }
        }
        flips += flipped;
        if (!flipped) break;
    }
    return flips;
}

}  // namespace

ClipCounts clip_mesh_to_half_space(Mesh& mesh, int axis, float value, int side, double snap, const Box* faces) {
    ClipCounts counts;
    const std::size_t nv = mesh.vertex_count(), nt = mesh.triangle_count();
    const double c = value, s = side > 0 ? 1.0 : -1.0;
    // Vertices near the plane move inside: the signed distances in [-2 snap, snap) are mapped onto
    // [-2 snap, -snap] by d -> -2 snap + (d + 2 snap) / 3, continuous and increasing, so that
    // afterwards every vertex is at least `snap` from the plane while the order of the vertices
    // along the axis is kept (a clamp onto one value would merge vertices and turn thin triangles
    // over).
    std::vector<double> d(nv);
    std::vector<std::uint8_t> out(nv), moved(nv);
    tbb::parallel_for(std::size_t(0), nv, [&](std::size_t v) {
        float& x = mesh.positions[3 * v + std::size_t(axis)];
        const double dist = s * (double(x) - c);
        if (dist >= -2.0 * snap && dist < snap) {
            x = float(c + s * (-2.0 * snap + (dist + 2.0 * snap) / 3.0));
            moved[v] = 1;
        }
        d[v] = s * (double(x) - c);
        out[v] = d[v] > 0.0;
    });
    for (std::uint8_t m : moved) counts.snapped += m;
    std::size_t outside = 0;
    for (std::uint8_t o : out) outside += o;
    if (outside == 0) return counts;

    Mesh res;
    res.attributes.resize(mesh.attributes.size());
    for (std::size_t i = 0; i < mesh.attributes.size(); ++i) {
        res.attributes[i].name = mesh.attributes[i].name;
        res.attributes[i].components = mesh.attributes[i].components;
    }
    const bool levels = mesh.vertex_level.size() == nv, kinds = mesh.triangle_kind.size() == nt;
    std::vector<std::uint32_t> remap(nv, kNone);
    for (std::size_t v = 0; v < nv; ++v) {
        if (out[v]) continue;
        remap[v] = std::uint32_t(res.vertex_count());
        res.positions.insert(res.positions.end(), &mesh.positions[3 * v], &mesh.positions[3 * v] + 3);
        if (levels) res.vertex_level.push_back(mesh.vertex_level[v]);
        copy_vertex_data(mesh, res, std::uint32_t(v));
    }
    const std::uint32_t first_cut = std::uint32_t(res.vertex_count());
    std::unordered_map<std::uint64_t, std::uint32_t> cut_of;
    std::vector<std::uint32_t> loop_next;  // per cut vertex: the next one along the cut's boundary
    // The vertex on edge (a, b), a inside, b outside: exactly on the plane, shared by both triangles.
    auto cut = [&](std::uint32_t a, std::uint32_t b) {
        const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
        auto [it, fresh] = cut_of.try_emplace(key, std::uint32_t(res.vertex_count()));
        if (!fresh) return it->second;
        const double t = d[a] / (d[a] - d[b]);
        for (int k = 0; k < 3; ++k) {
            const double pa = mesh.positions[3 * a + k], pb = mesh.positions[3 * b + k];
            res.positions.push_back(k == axis ? value : float(pa + t * (pb - pa)));
        }
        if (levels) res.vertex_level.push_back(std::min(mesh.vertex_level[a], mesh.vertex_level[b]));
        append_vertex_data(mesh, res, a, b, t);
        loop_next.push_back(kNone);
        return it->second;
    };
    auto emit = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c3, TriangleKind kind) {
        res.triangles.push_back(a);
        res.triangles.push_back(b);
        res.triangles.push_back(c3);
        if (kinds) res.triangle_kind.push_back(kind);
    };
    auto dist2 = [&](std::uint32_t p, std::uint32_t q) {
        double s2 = 0.0;
        for (int k = 0; k < 3; ++k) {
            const double e = double(res.positions[3 * p + k]) - res.positions[3 * q + k];
            s2 += e * e;
        }
        return s2;
    };
    for (std::size_t t = 0; t < nt; ++t) {
        const std::uint32_t* tri = &mesh.triangles[3 * t];
        const TriangleKind kind = kinds ? mesh.triangle_kind[t] : TriangleKind::Level2;
        const int n_out = out[tri[0]] + out[tri[1]] + out[tri[2]];
        if (n_out == 3) continue;
        if (n_out == 0) {
            emit(remap[tri[0]], remap[tri[1]], remap[tri[2]], kind);
            continue;
        }
        if (n_out == 1) {  // rotate: a, b inside, c outside
            int r = 0;
            while (!out[tri[(r + 2) % 3]]) ++r;
            const std::uint32_t a = tri[r], b = tri[(r + 1) % 3], cc = tri[(r + 2) % 3];
            const std::uint32_t bc = cut(b, cc), ca = cut(a, cc), na = remap[a], nb = remap[b];
            if (dist2(na, bc) <= dist2(nb, ca)) {  // the quad a, b, bc, ca along its shorter diagonal
                emit(na, nb, bc, kind);
                emit(na, bc, ca, kind);
            } else {
                emit(na, nb, ca, kind);
                emit(nb, bc, ca, kind);
            }
            loop_next[bc - first_cut] = ca;
        } else {  // a inside, b and c outside
            int r = 0;
            while (out[tri[r]]) ++r;
            const std::uint32_t a = tri[r], b = tri[(r + 1) % 3], cc = tri[(r + 2) % 3];
            const std::uint32_t ab = cut(a, b), ca = cut(a, cc);
            emit(remap[a], ab, ca, kind);
            loop_next[ab - first_cut] = ca;
        }
    }
    counts.cut_edges = loop_next.size();

    // The boundary loops, each in boundary order from its smallest cut vertex.
    const std::size_t nc = loop_next.size();
    std::vector<std::vector<std::uint32_t>> loops;
    std::vector<std::uint8_t> seen(nc, 0);
    for (std::size_t i = 0; i < nc; ++i) {
        if (seen[i]) continue;
        std::vector<std::uint32_t> loop;
        for (std::uint32_t j = std::uint32_t(i); j != kNone && !seen[j];) {
            seen[j] = 1;
            loop.push_back(j);
            j = loop_next[j] == kNone ? kNone : loop_next[j] - first_cut;
        }
        loops.push_back(std::move(loop));
    }
    // A triangle that crosses the plane near one of its vertices, steeply, is cut along a segment
    // far shorter than the vertex's distance to the plane: its two cut vertices may round to one
    // float point. Consecutive cut vertices of a loop closer than `snap` are merged (a collapse of
    // the boundary edge between them: its one triangle goes, the mesh stays closed).
    std::vector<std::uint32_t> rep(nc);
    for (std::size_t i = 0; i < nc; ++i) rep[i] = std::uint32_t(i);
    auto close = [&](std::uint32_t p, std::uint32_t q) { return dist2(first_cut + p, first_cut + q) < snap * snap; };
    std::size_t merged = 0;
    for (auto& loop : loops) {
        std::vector<std::uint32_t> anchors;
        for (std::uint32_t j : loop) {
            if (!anchors.empty() && close(anchors.back(), j)) rep[j] = anchors.back(), ++merged;
            else anchors.push_back(j);
        }
        while (anchors.size() > 1 && close(anchors.back(), anchors.front())) {
            for (std::uint32_t j : loop)
                if (rep[j] == anchors.back()) rep[j] = anchors.front();
            anchors.pop_back();
            ++merged;
        }
        loop = std::move(anchors);
    }
    if (merged && faces) {
        // A run merged across a box edge (members on different faces) goes to the edge: the
        // anchor takes every face coordinate a member lies on, so that no triangle of either face
        // leaves its face, and none turns over within it (a flat one is flipped away later).
        for (std::size_t i = 0; i < nc; ++i) {
            if (rep[i] == i) continue;
            const float* p = &res.positions[3 * (first_cut + i)];
            float* q = &res.positions[3 * (first_cut + rep[i])];
            for (int k = 0; k < 3; ++k)
                if (k != axis && (p[k] == faces->min[k] || p[k] == faces->max[k])) q[k] = p[k];
        }
    }
    if (merged) {
        std::size_t kept = 0;
        for (std::size_t t = 0; t < res.triangle_count(); ++t) {
            std::uint32_t v[3];
            for (int k = 0; k < 3; ++k) {
                v[k] = res.triangles[3 * t + k];
                if (v[k] >= first_cut) v[k] = first_cut + rep[v[k] - first_cut];
            }
            if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue;
            for (int k = 0; k < 3; ++k) res.triangles[3 * kept + k] = v[k];
            if (kinds) res.triangle_kind[kept] = res.triangle_kind[t];
            ++kept;
        }
        res.triangles.resize(3 * kept);
        if (kinds) res.triangle_kind.resize(kept);
    }
    // Cut vertices renumbered without the merged ones (their order kept).
    std::vector<std::uint32_t> cut_index(nc, kNone);
    std::uint32_t next_cut = 0;
    for (std::size_t i = 0; i < nc; ++i)
        if (rep[i] == i) cut_index[i] = next_cut++;
    if (merged) {
        auto compact = [&](auto& values, std::size_t per) {
            if (values.size() != per * (first_cut + nc)) return;
            for (std::size_t i = 0; i < nc; ++i)
                if (cut_index[i] != kNone)
                    for (std::size_t k = 0; k < per; ++k)
                        values[per * (first_cut + cut_index[i]) + k] = values[per * (first_cut + i) + k];
            values.resize(per * (first_cut + next_cut));
        };
        compact(res.positions, 3);
        compact(res.vertex_level, 1);
        compact(res.normals, 3);
        for (auto& a : res.attributes) compact(a.values, std::size_t(a.components));
        for (auto& v : res.triangles)
            if (v >= first_cut) v = first_cut + cut_index[v - first_cut];
        for (auto& loop : loops)
            for (auto& j : loop) j = cut_index[j];
    }

    // The cap: the loops reversed, in the plane's (u, v) with (u, v, outward normal) right-handed,
    // so that counter-clockwise cap triangles face outward.
    const int u = (axis + 1) % 3, w = (axis + 2) % 3;
    std::vector<Point2> pts(next_cut);
    for (std::size_t i = 0; i < pts.size(); ++i) {
        const float* p = &res.positions[3 * (first_cut + i)];
        pts[i] = side > 0 ? Point2{p[u], p[w]} : Point2{p[w], p[u]};
    }
    for (auto& loop : loops) std::reverse(loop.begin(), loop.end());
    const LoopTriangulation cap = triangulate_loops(pts, loops);
    for (std::size_t i = 0; i < cap.triangles.size(); i += 3)
        emit(first_cut + cap.triangles[i], first_cut + cap.triangles[i + 1], first_cut + cap.triangles[i + 2], TriangleKind::Patch);
    counts.cap_triangles = cap.triangles.size() / 3;
    counts.merged = merged;
    counts.forced = cap.forced;
    mesh = std::move(res);
    return counts;
}

ClipCounts clip_mesh_to_box(Mesh& mesh, const Box& box, float particle_radius) {
    ClipCounts total;
    for (int axis = 0; axis < 3; ++axis)
        for (int side : {1, -1}) {
            const float value = side > 0 ? box.max[axis] : box.min[axis];
            const float mag = std::fabs(value);
            const double ulp = double(std::nextafter(mag, INFINITY)) - double(mag);
            // Two float steps keep a cut point and the ends of its edge apart once rounded; more
            // merged cut vertices whole r apart far from the origin (64 steps: 2.5 r at 1e4 units),
            // and the merges left non-manifold edges (tests/test_mesh_clip.cpp, "far from the origin").
            const double snap = std::max(1e-3 * double(particle_radius), 2.0 * ulp);
            const ClipCounts c = clip_mesh_to_half_space(mesh, axis, value, side, snap, &box);
            total.cap_triangles += c.cap_triangles;
            total.cut_edges += c.cut_edges;
            total.snapped += c.snapped;
            total.forced += c.forced;
            total.merged += c.merged;
        }
    total.flipped = flip_bad_triangles(mesh, box);
    // Caps of one face that a later face cut are counted once more above: count those left.
    std::size_t on_faces = 0;
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
        const std::uint32_t* tri = &mesh.triangles[3 * t];
        bool on = false;
        for (int k = 0; k < 3 && !on; ++k)
            for (const float plane : {box.min[k], box.max[k]})
                on = on || (mesh.positions[3 * tri[0] + k] == plane && mesh.positions[3 * tri[1] + k] == plane &&
                            mesh.positions[3 * tri[2] + k] == plane);
        on_faces += on;
    }
    total.cap_triangles = on_faces;
    return total;
}

}  // namespace trilevel
