// Table generation for face-consistent marching cubes (docs/design.md §7); see marching_cubes.hpp.
#include "marching_cubes.hpp"

#include <stdexcept>
#include <vector>

namespace trilevel::mc {
namespace {

std::array<CubeEdge, 12> make_edges() {
    std::array<CubeEdge, 12> e{};
    for (int axis = 0; axis < 3; ++axis) {
        const int b = (axis + 1) % 3, c = (axis + 2) % 3;
        for (int j = 0; j < 4; ++j) {
            const int c0 = ((j & 1) << b) | ((j >> 1) << c);
            e[axis * 4 + j] = {axis, c0, c0 | (1 << axis)};
        }
    }
    return e;
}

int edge_between(const std::array<CubeEdge, 12>& edges, int ca, int cb) {
    for (int e = 0; e < 12; ++e)
        if ((edges[e].corner0 == ca && edges[e].corner1 == cb) || (edges[e].corner0 == cb && edges[e].corner1 == ca))
            return e;
    throw std::logic_error("marching cubes: corners are not adjacent");
}

// Face (axis, side) seen from outside: side 1 looks down -axis, (b, c) = (axis+1, axis+2) is
// counter-clockwise; side 0 looks the other way, so the same square is walked in reverse.
std::array<CubeFace, 6> make_faces() {
    const auto& edges = cube_edges();
    std::array<CubeFace, 6> faces{};
    constexpr int ccw[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    constexpr int cw[4][2] = {{0, 0}, {0, 1}, {1, 1}, {1, 0}};
    for (int axis = 0; axis < 3; ++axis) {
        const int b = (axis + 1) % 3, c = (axis + 2) % 3;
        for (int side = 0; side < 2; ++side) {
            CubeFace& f = faces[2 * axis + side];
            for (int k = 0; k < 4; ++k) {
                const int* bc = side ? ccw[k] : cw[k];
                f.corner[k] = (side << axis) | (bc[0] << b) | (bc[1] << c);
            }
            for (int k = 0; k < 4; ++k) f.edge[k] = edge_between(edges, f.corner[k], f.corner[(k + 1) % 4]);
        }
    }
    return faces;
}

// Do two cube edges lie on one face? A diagonal between them would be a chord of that face, and
// the neighbour across an ambiguous face could pick the same chord: an edge used four times.
bool cofacial(int e1, int e2) {
    for (const CubeFace& f : cube_faces()) {
        int hits = 0;
        for (int k = 0; k < 4; ++k) hits += (f.edge[k] == e1) + (f.edge[k] == e2);
        if (hits == 2) return true;
    }
    return false;
}

// Triangulates a cycle by clipping ears whose new diagonal is no face chord, trying the fan from
// the first vertex first. Returns false when no such triangulation exists.
bool triangulate_cycle(std::vector<int> poly, CubeCase& out) {
    const int n = int(poly.size());
    if (n == 3) {
        out.triangles[out.triangle_count++] = {std::uint8_t(poly[0]), std::uint8_t(poly[1]), std::uint8_t(poly[2])};
        return true;
    }
    for (int j = 1; j <= n; ++j) {
        const int i = j % n, prev = poly[(i + n - 1) % n], next = poly[(i + 1) % n];
        if (cofacial(prev, next)) continue;
        const CubeCase saved = out;
        out.triangles[out.triangle_count++] = {std::uint8_t(prev), std::uint8_t(poly[i]), std::uint8_t(next)};
        std::vector<int> rest = poly;
        rest.erase(rest.begin() + i);
        if (triangulate_cycle(rest, out)) return true;
        out = saved;
    }
    return false;
}

// Chains the 6 faces' segments into cycles and triangulates each cycle (docs/design.md §7).
CubeCase make_case(unsigned cube_case) {
    const auto& faces = cube_faces();
    std::array<int, 12> next;
    next.fill(-1);
    for (const CubeFace& f : faces) {
        unsigned mask = 0;
        for (int k = 0; k < 4; ++k) mask |= ((cube_case >> f.corner[k]) & 1u) << k;
        std::array<FaceSegment, 2> seg;
        const int n = face_segments(mask, seg);
        for (int s = 0; s < n; ++s) {
            const int from = f.edge[seg[s].from], to = f.edge[seg[s].to];
            if (next[from] != -1) throw std::logic_error("marching cubes: edge leaves twice");
            next[from] = to;
        }
    }
    CubeCase out;
    std::array<bool, 12> used{};
    for (int start = 0; start < 12; ++start) {
        if (next[start] < 0 || used[start]) continue;
        std::vector<int> cycle;
        for (int e = start; !used[e]; e = next[e]) {
            if (next[e] < 0) throw std::logic_error("marching cubes: open cycle");
            used[e] = true;
            cycle.push_back(e);
        }
        if (!triangulate_cycle(cycle, out)) throw std::logic_error("marching cubes: no chord-free triangulation");
    }
    return out;
}

}  // namespace

const std::array<CubeEdge, 12>& cube_edges() {
    static const std::array<CubeEdge, 12> edges = make_edges();
    return edges;
}

const std::array<CubeFace, 6>& cube_faces() {
    static const std::array<CubeFace, 6> faces = make_faces();
    return faces;
}

// Walking the corners counter-clockwise, edge k "enters" the inside when corner k is outside and
// corner k+1 inside, and "exits" in the opposite case. Each entry joins the next exit: this
// keeps the inside on the right and, on ambiguous faces, cuts every inside corner off alone.
int face_segments(unsigned inside_mask, std::array<FaceSegment, 2>& out) {
    auto in = [&](int k) { return ((inside_mask >> (k & 3)) & 1u) != 0; };
    int n = 0;
    for (int k = 0; k < 4; ++k) {
        if (in(k) || !in(k + 1)) continue;  // not an entry
        int exit = k + 1;
        while (in(exit + 1)) ++exit;
        out[n++] = {std::uint8_t(k), std::uint8_t(exit & 3)};
    }
    return n;
}

const std::array<CubeCase, 256>& case_table() {
    static const std::array<CubeCase, 256> table = [] {
        std::array<CubeCase, 256> t{};
        for (unsigned c = 0; c < 256; ++c) t[c] = make_case(c);
        return t;
    }();
    return table;
}

}  // namespace trilevel::mc
