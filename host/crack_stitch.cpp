// Crack closing on transition faces (docs/design.md §7); see crack_stitch.hpp.
#include "crack_stitch.hpp"

#include <array>
#include <utility>

#include "marching_cubes.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {
namespace {

struct DirEdge {
    std::int32_t from, to;
};

// Small fixed-capacity list: at most 2 + 4*2 directed edges per level-2 fine face.
template <class T, int N>
struct SmallVec {
    std::array<T, N> item;
    int size = 0;
    void push(T v) {
        if (size == N) throw Error("crack stitching: too many edges on one face");
        item[size++] = v;
    }
};

glm::ivec3 corner_offset(int corner) { return {corner & 1, (corner >> 1) & 1, (corner >> 2) & 1}; }

class FaceStitcher {
public:
    FaceStitcher(const Level3Block& b, int axis, int side, const FinePointMap& field)
        : b_(b), axis_(axis), side_(side), field_(field) {}

    std::size_t stitch(int u, int v, std::vector<std::uint32_t>& out, std::vector<std::uint32_t>& runs);

private:
    const Level3Block& b_;
    int axis_, side_;
    const FinePointMap& field_;
    SmallVec<DirEdge, 10> edges_;
    SmallVec<std::pair<std::int32_t, std::int32_t>, 96> used_;  // undirected edges of adjacent cubes
    bool used_known_ = false;
    int u_ = 0, v_ = 0;

    bool in_block(glm::ivec3 p) const {
        return glm::all(glm::greaterThanEqual(p, glm::ivec3(0))) && glm::all(glm::lessThanEqual(p, glm::ivec3(b_.n)));
    }
    int index(glm::ivec3 p) const { return (p.z * (b_.n + 1) + p.y) * (b_.n + 1) + p.x; }
    float value(glm::ivec3 p) const {
        if (in_block(p)) return b_.values[index(p)];
        const float* v = field_.find(b_.base + p);
        if (!v) throw Error("crack stitching: a level-2 point is missing from the fine point map");
        return *v;
    }
    std::int32_t unit_vertex(glm::ivec3 lower, int axis) const {
        const std::int32_t id = b_.slots[index(lower) * 3 + axis];
        if (id < 0) throw Error("crack stitching: a face crossing has no level-3 vertex (continuity missing?)");
        return id;
    }
    // Vertex of a level-2 edge from p to p+2e in the face: the unit sub-edge that holds the
    // crossing (docs/design.md §7). The midpoint is a level-3 point here, so its stored value (after
    // continuity) is what the level-2 midpoint rule gives the surface mesher's level-2 side.
    std::int32_t level2_vertex(glm::ivec3 p, int axis) const {
        glm::ivec3 e{0};
        e[axis] = 1;
        const float m = value(p + e);
        return unit_vertex(mc::inside(value(p)) != mc::inside(m) ? p : p + e, axis);
    }
    // Local point of corner k of the cube face (axis, face_side), face square at `origin`, `scale` steps.
    glm::ivec3 face_point(int face_side, int k, glm::ivec3 origin, int scale) const {
        glm::ivec3 o = corner_offset(mc::cube_faces()[2 * axis_ + face_side].corner[k]);
        o[axis_] = 0;
        return origin + scale * o;
    }
    void add_face_segments(int face_side, glm::ivec3 origin, int scale);
    void collect_used_edges();
    void add_cube_edges(glm::ivec3 origin, int scale, int face_side);
    bool is_used(std::int32_t a, std::int32_t b) {
        if (!used_known_) collect_used_edges();
        for (int i = 0; i < used_.size; ++i)
            if ((used_.item[i].first == a && used_.item[i].second == b) ||
                (used_.item[i].first == b && used_.item[i].second == a))
                return true;
        return false;
    }
    void triangulate(SmallVec<std::int32_t, 10>& poly, std::vector<std::uint32_t>& out);
    static void add_runs(const SmallVec<std::int32_t, 10>& cycle, const std::array<bool, 10>& level2_edge,
                         std::vector<std::uint32_t>& runs);
};

// Segments of one face square as directed vertex edges. The level-3 cubes see the face from the
// level-2 side (their face `side_`), the level-2 cube from the other (its face 1 - side_).
void FaceStitcher::add_face_segments(int face_side, glm::ivec3 origin, int scale) {
    std::array<glm::ivec3, 4> p;
    unsigned mask = 0;
    for (int k = 0; k < 4; ++k) {
        p[k] = face_point(face_side, k, origin, scale);
        mask |= unsigned(mc::inside(value(p[k]))) << k;
    }
    std::array<mc::FaceSegment, 2> seg;
    const int n = mc::face_segments(mask, seg);
    auto vertex = [&](int k) {
        const glm::ivec3 a = p[k], b = p[(k + 1) & 3];
        const glm::ivec3 d = b - a;
        const int ax = d.x ? 0 : d.y ? 1 : 2;
        const glm::ivec3 lower = glm::min(a, b);
        return scale == 1 ? unit_vertex(lower, ax) : level2_vertex(lower, ax);
    };
    for (int s = 0; s < n; ++s) edges_.push({vertex(seg[s].from), vertex(seg[s].to)});
}

// Undirected edges, both ends on this face, of one adjacent cube's marching-cubes triangles.
void FaceStitcher::add_cube_edges(glm::ivec3 origin, int scale, int face_side) {
    float v[8];
    for (int c = 0; c < 8; ++c) v[c] = value(origin + scale * corner_offset(c));
    const mc::CubeCase& cc = mc::case_table()[mc::case_index(v)];
    const auto& face = mc::cube_faces()[2 * axis_ + face_side];
    auto face_vertex = [&](int e) -> std::int32_t {
        for (int k = 0; k < 4; ++k)
            if (face.edge[k] == e) {
                const auto& ce = mc::cube_edges()[e];
                const glm::ivec3 lower = origin + scale * corner_offset(ce.corner0);
                return scale == 1 ? unit_vertex(lower, ce.axis) : level2_vertex(lower, ce.axis);
            }
        return -1;
    };
    for (int t = 0; t < cc.triangle_count; ++t)
        for (int k = 0; k < 3; ++k) {
            const std::int32_t a = face_vertex(cc.triangles[t][k]), b = face_vertex(cc.triangles[t][(k + 1) % 3]);
            if (a >= 0 && b >= 0) used_.push({a, b});
        }
}

void FaceStitcher::collect_used_edges() {
    used_known_ = true;
    const int plane = side_ * b_.n;
    glm::ivec3 o{0};
    o[(axis_ + 1) % 3] = 2 * u_;
    o[(axis_ + 2) % 3] = 2 * v_;
    glm::ivec3 l2 = o;
    l2[axis_] = side_ ? plane : plane - 2;
    add_cube_edges(l2, 2, 1 - side_);
    for (int dv = 0; dv < 2; ++dv)
        for (int du = 0; du < 2; ++du) {
            glm::ivec3 l3 = o;
            l3[(axis_ + 1) % 3] += du;
            l3[(axis_ + 2) % 3] += dv;
            l3[axis_] = side_ ? plane - 1 : plane;
            add_cube_edges(l3, 1, side_);
        }
}

double orient2d(glm::dvec2 a, glm::dvec2 b, glm::dvec2 c) {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// Ear clipping in the face plane; topology first: an ear must not repeat an edge the adjacent
// cubes use. Among the allowed vertices: a strict ear (convex, no other vertex in or on it), then an
// ear that only touches other vertices on its boundary (repeated or collinear crossings, which
// exact zeros of the field make; not at its tip), then a flat one (a zero-area triangle folds
// nothing); the last triangle must not turn the other way either. Where those
// choices run into a polygon with no allowed ear left, the next choice is tried instead (at most 10
// vertices: a small search); only when no sequence of ears exists is a reflex vertex cut, as a
// last resort the first one, which folds the patch.
void FaceStitcher::triangulate(SmallVec<std::int32_t, 10>& poly, std::vector<std::uint32_t>& out) {
    const int pb = (axis_ + 1) % 3, pc = (axis_ + 2) % 3;
    auto pt = [&](std::int32_t id) { return glm::dvec2(b_.positions[id][pb], b_.positions[id][pc]); };
    double area = 0.0;
    for (int i = 0; i < poly.size; ++i) {
        const glm::dvec2 a = pt(poly.item[i]), c = pt(poly.item[(i + 1) % poly.size]);
        area += a.x * c.y - a.y * c.x;
    }
    const double sign = area >= 0.0 ? 1.0 : -1.0;
    enum Ear { kStrict, kTouching, kFlat, kNone };
    auto ear = [&](const SmallVec<std::int32_t, 10>& q, int i) {
        const int n = q.size;
        const glm::dvec2 a = pt(q.item[(i + n - 1) % n]), b = pt(q.item[i]), c = pt(q.item[(i + 1) % n]);
        const double turn = sign * orient2d(a, b, c);
        if (turn < 0.0) return kNone;
        if (turn == 0.0) return kFlat;
        Ear kind = kStrict;
        for (int j = 0; j < n; ++j) {
            if (j == i || j == (i + 1) % n || j == (i + n - 1) % n) continue;
            const glm::dvec2 p = pt(q.item[j]);
            if (p == b) return kNone;  // a repeated tip: what is left would turn the other way there
            const double s0 = sign * orient2d(a, b, p), s1 = sign * orient2d(b, c, p), s2 = sign * orient2d(c, a, p);
            if (s0 > 0.0 && s1 > 0.0 && s2 > 0.0) return kNone;  // inside
            if (s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) kind = kTouching;
        }
        return kind;
    };
    auto allowed = [&](const SmallVec<std::int32_t, 10>& q, int i) {
        return !is_used(q.item[(i + q.size - 1) % q.size], q.item[(i + 1) % q.size]);
    };
    auto clip = [&](SmallVec<std::int32_t, 10>& q, int pick, std::vector<std::uint32_t>& to) {
        const int n = q.size;
        to.insert(to.end(), {std::uint32_t(q.item[(pick + n - 1) % n]), std::uint32_t(q.item[pick]),
                             std::uint32_t(q.item[(pick + 1) % n])});
        for (int j = pick; j + 1 < n; ++j) q.item[j] = q.item[j + 1];
        --q.size;
    };
    // Depth-first over the ears in order of preference; the first path is the greedy one.
    int budget = 4096;  // ear tests; polygons that need more keep the fallback below
    std::vector<std::uint32_t> found;
    auto search = [&](auto&& self, SmallVec<std::int32_t, 10> q) -> bool {
        if (q.size == 3) {
            if (sign * orient2d(pt(q.item[0]), pt(q.item[1]), pt(q.item[2])) < 0.0) return false;
            found.insert(found.end(), {std::uint32_t(q.item[0]), std::uint32_t(q.item[1]), std::uint32_t(q.item[2])});
            return true;
        }
        for (Ear want : {kStrict, kTouching, kFlat})
            for (int i = 0; i < q.size; ++i) {
                if (--budget < 0) return false;
                if (ear(q, i) != want || !allowed(q, i)) continue;
                const std::size_t mark = found.size();
                SmallVec<std::int32_t, 10> rest = q;
                clip(rest, i, found);
                if (self(self, rest)) return true;
                found.resize(mark);
            }
        return false;
    };
    if (search(search, poly)) {
        out.insert(out.end(), found.begin(), found.end());
        return;
    }
    while (poly.size > 3) {
        int pick = -1;
        for (Ear want : {kStrict, kTouching, kFlat})
            for (int i = 0; i < poly.size && pick < 0; ++i)
                if (ear(poly, i) == want && allowed(poly, i)) pick = i;
        for (int i = 0; i < poly.size && pick < 0; ++i)
            if (allowed(poly, i)) pick = i;
        clip(poly, pick < 0 ? 0 : pick, out);
    }
    out.insert(out.end(), {std::uint32_t(poly.item[0]), std::uint32_t(poly.item[1]), std::uint32_t(poly.item[2])});
}

// The cycle's level-3 runs from one level-2 crossing to the next that pass inner crossings
// (level2_edge[i]: the edge leaving cycle[i] is a level-2 face segment), as (length, vertices...).
void FaceStitcher::add_runs(const SmallVec<std::int32_t, 10>& cycle, const std::array<bool, 10>& level2_edge,
                            std::vector<std::uint32_t>& runs) {
    const int n = cycle.size;
    auto outer = [&](int i) { return level2_edge[i % n] || level2_edge[(i + n - 1) % n]; };
    for (int i = 0; i < n; ++i) {
        if (!outer(i) || level2_edge[i] || outer(i + 1)) continue;  // starts a run with an inner vertex
        const std::size_t head = runs.size();
        runs.push_back(0);
        int j = i;
        do runs.push_back(std::uint32_t(cycle.item[j++ % n]));
        while (!outer(j));  // ends at the next level-2 crossing (outer(i + n) at the latest)
        runs.push_back(std::uint32_t(cycle.item[j % n]));
        runs[head] = std::uint32_t(runs.size() - head - 1);
    }
}

std::size_t FaceStitcher::stitch(int u, int v, std::vector<std::uint32_t>& out, std::vector<std::uint32_t>& runs) {
    u_ = u;
    v_ = v;
    edges_.size = 0;
    used_.size = 0;
    used_known_ = false;
    glm::ivec3 o{0};
    o[axis_] = side_ * b_.n;
    o[(axis_ + 1) % 3] = 2 * u;
    o[(axis_ + 2) % 3] = 2 * v;
    add_face_segments(1 - side_, o, 2);
    const int level2_edges = edges_.size;
    for (int dv = 0; dv < 2; ++dv)
        for (int du = 0; du < 2; ++du) {
            glm::ivec3 q = o;
            q[(axis_ + 1) % 3] += du;
            q[(axis_ + 2) % 3] += dv;
            add_face_segments(side_, q, 1);
        }
    std::size_t patches = 0;
    std::array<bool, 10> done{};
    for (int s = 0; s < edges_.size; ++s) {
        if (done[s]) continue;
        SmallVec<std::int32_t, 10> cycle;
        std::array<bool, 10> level2_edge{};
        for (int e = s;;) {
            done[e] = true;
            level2_edge[cycle.size] = e < level2_edges;
            cycle.push(edges_.item[e].from);
            int next = -1;
            for (int f = 0; f < edges_.size; ++f)
                if (edges_.item[f].from == edges_.item[e].to) {
                    if (next >= 0) throw Error("crack stitching: two edges leave one vertex");
                    next = f;
                }
            if (next < 0) throw Error("crack stitching: open crack polygon");
            if (next == s) break;
            if (done[next]) throw Error("crack stitching: crack polygons share a vertex");
            e = next;
        }
        if (cycle.size < 3) continue;
        add_runs(cycle, level2_edge, runs);
        // Patches run opposite to the cycle, so every crack edge is used once each way.
        SmallVec<std::int32_t, 10> poly;
        for (int i = cycle.size - 1; i >= 0; --i) poly.push(cycle.item[i]);
        patches += std::size_t(poly.size - 2);
        triangulate(poly, out);
    }
    return patches;
}

}  // namespace

std::size_t stitch_transition_face(const Level3Block& block, int axis, int side, const FinePointMap& field,
                                   std::vector<std::uint32_t>& out, std::vector<std::uint32_t>& runs) {
    FaceStitcher stitcher(block, axis, side, field);
    std::size_t patches = 0;
    for (int v = 0; v < block.n / 2; ++v)
        for (int u = 0; u < block.n / 2; ++u) patches += stitcher.stitch(u, v, out, runs);
    return patches;
}

}  // namespace trilevel
