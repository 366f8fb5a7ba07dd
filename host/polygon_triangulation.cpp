// Ear clipping with hole bridges; see polygon_triangulation.hpp. The polygon is a doubly linked
// ring of nodes; a bridge to a hole duplicates its two ends (same vertex id), so the ring stays one
// weakly simple polygon. Outer rings run counter-clockwise, holes clockwise, and an ear
// (prev, ear, next) is a counter-clockwise triangle.
#include "polygon_triangulation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#include <tbb/parallel_for.h>

namespace trilevel {
namespace {

struct Node {
    std::uint32_t id = 0;  // vertex id
    double x = 0.0, y = 0.0;
    int prev = -1, next = -1;
};

class Ring {
public:
    std::vector<Node> nodes;
    std::vector<std::uint32_t>* out = nullptr;
    std::size_t forced = 0;

    /// Appends a ring of `loop` in the given direction; returns a node of it.
    int add_loop(const std::vector<Point2>& pts, const std::vector<std::uint32_t>& loop, bool reversed) {
        const int first = int(nodes.size()), n = int(loop.size());
        for (int k = 0; k < n; ++k) {
            const std::uint32_t id = loop[std::size_t(reversed ? n - 1 - k : k)];
            Node nd;
            nd.id = id;
            nd.x = pts[id].x;
            nd.y = pts[id].y;
            nd.prev = first + (k + n - 1) % n;
            nd.next = first + (k + 1) % n;
            nodes.push_back(nd);
        }
        return first;
    }

    Node& at(int i) { return nodes[std::size_t(i)]; }

    // Minus twice the signed area of (p, q, r): negative for a convex corner of a counter-clockwise ring.
    double area(int p, int q, int r) {
        const Node &a = at(p), &b = at(q), &c = at(r);
        return (b.y - a.y) * (c.x - b.x) - (b.x - a.x) * (c.y - b.y);
    }
    static bool in_triangle(double ax, double ay, double bx, double by, double cx, double cy, double px, double py) {
        return (cx - px) * (ay - py) >= (ax - px) * (cy - py) && (ax - px) * (by - py) >= (bx - px) * (ay - py) &&
               (bx - px) * (cy - py) >= (cx - px) * (by - py);
    }
    bool equals(int p, int q) { return at(p).x == at(q).x && at(p).y == at(q).y; }
    static int sign(double v) { return (v > 0) - (v < 0); }
    bool on_segment(int p, int q, int r) {
        return at(q).x <= std::max(at(p).x, at(r).x) && at(q).x >= std::min(at(p).x, at(r).x) &&
               at(q).y <= std::max(at(p).y, at(r).y) && at(q).y >= std::min(at(p).y, at(r).y);
    }
    bool intersects(int p1, int q1, int p2, int q2) {
        const int o1 = sign(area(p1, q1, p2)), o2 = sign(area(p1, q1, q2));
        const int o3 = sign(area(p2, q2, p1)), o4 = sign(area(p2, q2, q1));
        if (o1 != o2 && o3 != o4) return true;
        if (o1 == 0 && on_segment(p1, p2, q1)) return true;
        if (o2 == 0 && on_segment(p1, q2, q1)) return true;
        if (o3 == 0 && on_segment(p2, p1, q2)) return true;
        if (o4 == 0 && on_segment(p2, q1, q2)) return true;
        return false;
    }
    bool intersects_polygon(int a, int b) {
        int p = a;
        do {
            const int q = at(p).next;
            if (at(p).id != at(a).id && at(q).id != at(a).id && at(p).id != at(b).id && at(q).id != at(b).id &&
                intersects(p, q, a, b))
                return true;
            p = q;
        } while (p != a);
        return false;
    }
    bool locally_inside(int a, int b) {
        return area(at(a).prev, a, at(a).next) < 0 ? area(a, b, at(a).next) >= 0 && area(a, at(a).prev, b) >= 0
                                                   : area(a, b, at(a).prev) < 0 || area(a, at(a).next, b) < 0;
    }
    bool middle_inside(int a, int b) {
        int p = a;
        bool inside = false;
        const double px = (at(a).x + at(b).x) / 2, py = (at(a).y + at(b).y) / 2;
        do {
            const Node &u = at(p), &v = at(u.next);
            if (((u.y > py) != (v.y > py)) && v.y != u.y && (px < (v.x - u.x) * (py - u.y) / (v.y - u.y) + u.x)) inside = !inside;
            p = u.next;
        } while (p != a);
        return inside;
    }
    bool valid_diagonal(int a, int b) {
        return at(at(a).next).id != at(b).id && at(at(a).prev).id != at(b).id && !intersects_polygon(a, b) &&
               ((locally_inside(a, b) && locally_inside(b, a) && middle_inside(a, b) &&
                 (area(at(a).prev, a, at(b).prev) != 0 || area(a, at(b).prev, b) != 0)) ||
                (equals(a, b) && area(at(a).prev, a, at(a).next) > 0 && area(at(b).prev, b, at(b).next) > 0));
    }
    /// Links a to b with a bridge: a and b are duplicated, giving two rings; returns b's copy side.
    int split(int a, int b) {
        Node a2 = at(a), b2 = at(b);
        const int ia2 = int(nodes.size()), ib2 = ia2 + 1;
        const int an = at(a).next, bp = at(b).prev;
        nodes.push_back(a2);
        nodes.push_back(b2);
        at(a).next = b;
        at(b).prev = a;
        at(ia2).next = an;
        at(an).prev = ia2;
        at(ib2).next = ia2;
        at(ia2).prev = ib2;
        at(bp).next = ib2;
        at(ib2).prev = bp;
        return ib2;
    }
    void remove(int p) {
        at(at(p).next).prev = at(p).prev;
        at(at(p).prev).next = at(p).next;
    }
    void emit(int a, int b, int c) {
        out->push_back(at(a).id);
        out->push_back(at(b).id);
        out->push_back(at(c).id);
    }

    bool is_ear(int ear) {
        const int a = at(ear).prev, b = ear, c = at(ear).next;
        if (area(a, b, c) >= 0) return false;  // reflex or flat
        const Node &A = at(a), &B = at(b), &C = at(c);
        const double x0 = std::min({A.x, B.x, C.x}), x1 = std::max({A.x, B.x, C.x});
        const double y0 = std::min({A.y, B.y, C.y}), y1 = std::max({A.y, B.y, C.y});
        for (int p = C.next; p != a; p = at(p).next) {
            const Node& P = at(p);
            if (P.x < x0 || P.x > x1 || P.y < y0 || P.y > y1) continue;
            if ((P.x == A.x && P.y == A.y) || (P.x == C.x && P.y == C.y)) continue;  // a bridge's copy
            if (in_triangle(A.x, A.y, B.x, B.y, C.x, C.y, P.x, P.y) && area(P.prev, p, P.next) >= 0) return false;
        }
        return true;
    }

    /// Cuts ears until two nodes are left; when none is found, splits the ring along a valid
    /// diagonal, and failing that cuts the most convex corner anyway (counted in `forced`).
    void clip(int ear) {
        int stop = ear;
        while (at(ear).prev != at(ear).next) {
            const int prev = at(ear).prev, next = at(ear).next;
            if (is_ear(ear)) {
                emit(prev, ear, next);
                remove(ear);
                ear = at(next).next;
                stop = ear;
                continue;
            }
            ear = next;
            if (ear == stop) {
                if (!split_clip(ear)) force(ear);
                return;
            }
        }
    }
    bool split_clip(int start) {
        int a = start;
        do {
            for (int b = at(at(a).next).next; b != at(a).prev; b = at(b).next) {
                if (at(a).id != at(b).id && valid_diagonal(a, b)) {
                    const int c = split(a, b);
                    clip(a);
                    clip(c);
                    return true;
                }
            }
            a = at(a).next;
        } while (a != start);
        return false;
    }
    void force(int start) {
        while (at(start).prev != at(start).next) {
            int best = start;
            double best_area = std::numeric_limits<double>::infinity();
            int p = start;
            do {
                const double s = area(at(p).prev, p, at(p).next);
                if (s < best_area) best_area = s, best = p;
                p = at(p).next;
            } while (p != start);
            const int prev = at(best).prev, next = at(best).next;
            emit(prev, best, next);
            ++forced;
            remove(best);
            start = next;
            if (is_ear(start) || (at(start).prev != at(start).next && is_ear(at(start).next))) {
                clip(start);
                return;
            }
        }
    }

    /// The node of the outer ring a hole's leftmost node `hole` is bridged to (earcut's search:
    /// the ray to -x, then the visible reflex node of least angle), or -1.
    int bridge_target(int hole, int outer) {
        int p = outer, m = -1;
        const double hx = at(hole).x, hy = at(hole).y;
        double qx = -std::numeric_limits<double>::infinity();
        do {
            const Node &P = at(p), &N = at(P.next);
            if (hy <= P.y && hy >= N.y && N.y != P.y) {
                const double x = P.x + (hy - P.y) * (N.x - P.x) / (N.y - P.y);
                if (x <= hx && x > qx) {
                    qx = x;
                    m = P.x < N.x ? p : P.next;
                    if (x == hx) return m;
                }
            }
            p = P.next;
        } while (p != outer);
        if (m < 0) return -1;
        const int stop = m;
        const double mx = at(m).x, my = at(m).y;
        double tan_min = std::numeric_limits<double>::infinity();
        p = m;
        do {
            const Node& P = at(p);
            if (hx >= P.x && P.x >= mx && hx != P.x &&
                in_triangle(hy < my ? hx : qx, hy, mx, my, hy < my ? qx : hx, hy, P.x, P.y)) {
                const double tan = std::fabs(hy - P.y) / (hx - P.x);
                if (locally_inside(p, hole) &&
                    (tan < tan_min || (tan == tan_min && (P.x > at(m).x || (P.x == at(m).x && sector_contains(m, p)))))) {
                    m = p;
                    tan_min = tan;
                }
            }
            p = P.next;
        } while (p != stop);
        return m;
    }
    bool sector_contains(int m, int p) { return area(at(m).prev, m, at(p).prev) < 0 && area(at(p).next, m, at(m).next) < 0; }
};

double loop_area(const std::vector<Point2>& pts, const std::vector<std::uint32_t>& loop) {
    double a = 0.0;
    for (std::size_t k = 0, n = loop.size(); k < n; ++k) {
        const Point2 &p = pts[loop[k]], &q = pts[loop[(k + 1) % n]];
        a += p.x * q.y - q.x * p.y;
    }
    return 0.5 * a;
}

bool point_in_loop(const std::vector<Point2>& pts, const std::vector<std::uint32_t>& loop, Point2 q) {
    bool inside = false;
    for (std::size_t k = 0, n = loop.size(), j = n - 1; k < n; j = k++) {
        const Point2 &a = pts[loop[k]], &b = pts[loop[j]];
        if ((a.y > q.y) != (b.y > q.y) && q.x < (b.x - a.x) * (q.y - a.y) / (b.y - a.y) + a.x) inside = !inside;
    }
    return inside;
}

struct Group {
    std::uint32_t outer = 0;
    bool reversed = false;  // an unowned clockwise loop, triangulated reversed, its triangles flipped
    std::vector<std::uint32_t> holes;
};

void triangulate_group(const std::vector<Point2>& pts, const std::vector<std::vector<std::uint32_t>>& loops,
                       const Group& g, std::vector<std::uint32_t>& out, std::size_t& forced) {
    Ring ring;
    ring.out = &out;
    std::size_t total = loops[g.outer].size();
    for (auto h : g.holes) total += loops[h].size();
    ring.nodes.reserve(total + 4 * g.holes.size() + 16);
    int outer = ring.add_loop(pts, loops[g.outer], g.reversed);
    // holes from left to right, each bridged at its leftmost node (earcut's eliminateHoles)
    std::vector<std::pair<int, std::uint32_t>> lefts;
    for (auto h : g.holes) {
        const int first = ring.add_loop(pts, loops[h], false);
        int left = first;
        for (int k = first; k < first + int(loops[h].size()); ++k)
            if (ring.at(k).x < ring.at(left).x || (ring.at(k).x == ring.at(left).x && ring.at(k).y < ring.at(left).y)) left = k;
        lefts.emplace_back(left, h);
    }
    std::sort(lefts.begin(), lefts.end(), [&](const auto& a, const auto& b) {
        const Node &p = ring.at(a.first), &q = ring.at(b.first);
        return p.x != q.x ? p.x < q.x : (p.y != q.y ? p.y < q.y : a.second < b.second);
    });
    const std::size_t before = out.size();
    for (const auto& [hole, h] : lefts) {
        int target = ring.bridge_target(hole, outer);
        if (target < 0) {  // no edge to its left (crossing input): bridge to the nearest outer node
            double best = INFINITY;
            int p = outer;
            do {
                const double dx = ring.at(p).x - ring.at(hole).x, dy = ring.at(p).y - ring.at(hole).y;
                if (dx * dx + dy * dy < best) best = dx * dx + dy * dy, target = p;
                p = ring.at(p).next;
            } while (p != outer);
            ++ring.forced;
        }
        ring.split(target, hole);
    }
    ring.clip(outer);
    forced += ring.forced;
    if (g.reversed)
        for (std::size_t t = before; t < out.size(); t += 3) std::swap(out[t + 1], out[t + 2]);
}

}  // namespace

LoopTriangulation triangulate_loops(const std::vector<Point2>& points, const std::vector<std::vector<std::uint32_t>>& loops) {
    const std::size_t n = loops.size();
    std::vector<double> area(n, 0.0);
    std::vector<std::array<double, 4>> box(n);
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
        if (loops[i].size() < 3) return;
        area[i] = loop_area(points, loops[i]);
        std::array<double, 4> b = {INFINITY, INFINITY, -INFINITY, -INFINITY};
        for (auto v : loops[i]) {
            b[0] = std::min(b[0], points[v].x), b[1] = std::min(b[1], points[v].y);
            b[2] = std::max(b[2], points[v].x), b[3] = std::max(b[3], points[v].y);
        }
        box[i] = b;
    });
    std::vector<std::uint32_t> outers;
    for (std::size_t i = 0; i < n; ++i)
        if (loops[i].size() >= 3 && area[i] >= 0) outers.push_back(std::uint32_t(i));
    std::vector<Group> groups(outers.size());
    std::vector<std::int64_t> group_of(n, -1);
    for (std::size_t k = 0; k < outers.size(); ++k) groups[k].outer = outers[k], group_of[outers[k]] = std::int64_t(k);
    // each hole joins the smallest outer loop around it (loops do not cross: one vertex decides)
    std::vector<std::int64_t> owner(n, -1);
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
        if (loops[i].size() < 3 || area[i] >= 0) return;
        const Point2 q = points[loops[i][0]];
        double best = INFINITY;
        for (std::size_t k = 0; k < outers.size(); ++k) {
            const auto o = outers[k];
            const auto& b = box[o];
            if (area[o] >= best || q.x < b[0] || q.y < b[1] || q.x > b[2] || q.y > b[3]) continue;
            if (box[i][0] < b[0] || box[i][1] < b[1] || box[i][2] > b[2] || box[i][3] > b[3]) continue;
            if (point_in_loop(points, loops[o], q)) best = area[o], owner[i] = std::int64_t(k);
        }
    });
    for (std::size_t i = 0; i < n; ++i) {
        if (loops[i].size() < 3 || area[i] >= 0) continue;
        if (owner[i] >= 0) groups[std::size_t(owner[i])].holes.push_back(std::uint32_t(i));
        else {
            Group g;
            g.outer = std::uint32_t(i);
            g.reversed = true;
            groups.push_back(g);
        }
    }
    std::vector<std::vector<std::uint32_t>> parts(groups.size());
    std::vector<std::size_t> forced(groups.size(), 0);
    tbb::parallel_for(std::size_t(0), groups.size(), [&](std::size_t k) { triangulate_group(points, loops, groups[k], parts[k], forced[k]); });
    LoopTriangulation result;
    std::size_t total = 0;
    for (const auto& p : parts) total += p.size();
    result.triangles.reserve(total);
    for (std::size_t k = 0; k < groups.size(); ++k) {
        result.triangles.insert(result.triangles.end(), parts[k].begin(), parts[k].end());
        result.forced += forced[k];
    }
    return result;
}

}  // namespace trilevel
