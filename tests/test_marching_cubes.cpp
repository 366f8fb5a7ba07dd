// Marching-cubes table, uniform-level meshing, topology check, determinism ([mesh]).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "marching_cubes.hpp"
#include "mesh_test_support.hpp"
#include "reference/edge_refinement.hpp"
#include "surface_mesher.hpp"
#include "test_support.hpp"

using namespace trilevel;

namespace {

using EdgeSet = std::multiset<std::pair<int, int>>;

// Directed face segments of one case as cube-edge pairs.
EdgeSet case_segments(unsigned c) {
    EdgeSet s;
    for (const mc::CubeFace& f : mc::cube_faces()) {
        unsigned mask = 0;
        for (int k = 0; k < 4; ++k) mask |= ((c >> f.corner[k]) & 1u) << k;
        std::array<mc::FaceSegment, 2> seg;
        const int n = mc::face_segments(mask, seg);
        for (int i = 0; i < n; ++i) s.insert({f.edge[seg[i].from], f.edge[seg[i].to]});
    }
    return s;
}

// Directed triangle edges of one case whose reverse is not also used: the polygon boundary.
EdgeSet case_boundary(unsigned c) {
    EdgeSet all;
    const mc::CubeCase& cc = mc::case_table()[c];
    for (int t = 0; t < cc.triangle_count; ++t)
        for (int k = 0; k < 3; ++k) all.insert({cc.triangles[t][k], cc.triangles[t][(k + 1) % 3]});
    EdgeSet open;
    for (const auto& e : all)
        if (!all.count({e.second, e.first})) open.insert(e);
    return open;
}

bool has_ambiguous_face(unsigned c) {
    for (const mc::CubeFace& f : mc::cube_faces()) {
        unsigned mask = 0;
        for (int k = 0; k < 4; ++k) mask |= ((c >> f.corner[k]) & 1u) << k;
        if (mask == 5 || mask == 10) return true;
    }
    return false;
}

Mesh mesh_of(const std::vector<CoarseCell>& cells, const LatticeFrame& frame, FinePointMap& field) {
    return triangulate_cells(cells, frame, field);
}

}  // namespace

TEST_CASE("face segments: single corners, ambiguous faces, reversal", "[mesh]") {
    std::array<mc::FaceSegment, 2> s;
    REQUIRE(mc::face_segments(0, s) == 0);
    REQUIRE(mc::face_segments(15, s) == 0);
    REQUIRE(mc::face_segments(1, s) == 1);  // corner 0 cut off: enters on edge 3, leaves on edge 0
    CHECK((s[0].from == 3 && s[0].to == 0));
    REQUIRE(mc::face_segments(5, s) == 2);  // inside corners 0 and 2 kept apart
    CHECK(((s[0].from == 1 && s[0].to == 2) || (s[0].from == 3 && s[0].to == 0)));
    // Seen from the other side (corner order reversed) every segment reverses.
    for (unsigned mask = 0; mask < 16; ++mask) {
        unsigned rev = 0;  // reversed order: corners 0,3,2,1; reversed face edge k' joins k' and k'+1
        const int map_corner[4] = {0, 3, 2, 1};
        for (int k = 0; k < 4; ++k) rev |= ((mask >> map_corner[k]) & 1u) << k;
        std::array<mc::FaceSegment, 2> a, b;
        const int na = mc::face_segments(mask, a), nb = mc::face_segments(rev, b);
        REQUIRE(na == nb);
        const int edge_of_rev[4] = {3, 2, 1, 0};  // reversed edge k' = original edge
        std::set<std::pair<int, int>> fa, fb;
        for (int i = 0; i < na; ++i) fa.insert({a[i].to, a[i].from});
        for (int i = 0; i < nb; ++i) fb.insert({edge_of_rev[b[i].from], edge_of_rev[b[i].to]});
        CHECK(fa == fb);
    }
}

TEST_CASE("marching-cubes table: all 256 cases close up with their face segments", "[mesh]") {
    const auto& table = mc::case_table();
    CHECK(table[0].triangle_count == 0);
    CHECK(table[255].triangle_count == 0);
    int max_triangles = 0;
    for (unsigned c = 0; c < 256; ++c) {
        INFO("case " << c);
        CHECK(case_boundary(c) == case_segments(c));
        max_triangles = std::max<int>(max_triangles, table[c].triangle_count);
        for (int t = 0; t < table[c].triangle_count; ++t) {
            const auto& tri = table[c].triangles[t];
            CHECK((tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2]));
        }
        // Complementary cases: same crossing edges; without ambiguous faces, reversed segments.
        const unsigned inv = 255u - c;
        std::set<int> ea, eb;
        for (const auto& e : case_segments(c)) ea.insert(e.first);
        for (const auto& e : case_segments(inv)) eb.insert(e.first);
        CHECK(ea == eb);
        if (!has_ambiguous_face(c)) {
            EdgeSet rev;
            for (const auto& e : case_segments(c)) rev.insert({e.second, e.first});
            CHECK(rev == case_segments(inv));
        }
    }
    CHECK(max_triangles <= 10);
}

TEST_CASE("marching-cubes table: no triangle edge is a chord between two segments of one face", "[mesh]") {
    // Such a chord could be picked by the neighbour across an ambiguous face as well (docs/design.md §7).
    for (unsigned c = 0; c < 256; ++c) {
        const EdgeSet segments = case_segments(c);
        const mc::CubeCase& cc = mc::case_table()[c];
        for (int t = 0; t < cc.triangle_count; ++t)
            for (int k = 0; k < 3; ++k) {
                const int a = cc.triangles[t][k], b = cc.triangles[t][(k + 1) % 3];
                if (segments.count({a, b}) || segments.count({b, a})) continue;
                for (const mc::CubeFace& f : mc::cube_faces()) {
                    const bool has_a = std::count(f.edge.begin(), f.edge.end(), a) > 0;
                    const bool has_b = std::count(f.edge.begin(), f.edge.end(), b) > 0;
                    INFO("case " << c << " edge " << a << "-" << b);
                    CHECK_FALSE((has_a && has_b));
                }
            }
    }
}

TEST_CASE("mesh topology report detects open, flipped and duplicated edges", "[mesh]") {
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    m.triangles = {0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2};  // closed tetrahedron
    CHECK(is_closed_and_oriented(m));
    CHECK(mesh_topology_report(m).edges == 6);
    Mesh open = m;
    open.triangles.resize(9);
    CHECK_FALSE(is_closed_and_oriented(open));
    CHECK(mesh_topology_report(open).boundary_edges == 3);
    Mesh flipped = m;
    std::swap(flipped.triangles[0], flipped.triangles[1]);
    CHECK(mesh_topology_report(flipped).orientation_conflicts == 3);
    Mesh twice = m;
    twice.triangles.insert(twice.triangles.end(), m.triangles.begin(), m.triangles.end());
    CHECK(mesh_topology_report(twice).non_manifold_edges == 6);
    Mesh degenerate = m;
    degenerate.triangles[1] = 0;
    CHECK_FALSE(is_closed_and_oriented(degenerate));
    // is_closed_and_oriented decides around each vertex; the report counts edges: the same verdict.
    Mesh two = m;  // two tetrahedra sharing vertex 0: closed, each edge used twice
    two.positions.insert(two.positions.end(), {-1, 0, 0, 0, -1, 0, 0, 0, -1});
    two.triangles.insert(two.triangles.end(), {0, 4, 5, 0, 6, 4, 0, 5, 6, 4, 6, 5});
    Mesh bad_index = m;
    bad_index.triangles[4] = 9;
    Mesh ragged = m;
    ragged.triangles.pop_back();
    Mesh fan = m;  // a third triangle on edge 1-2 and its reverse elsewhere: every count balanced but edge 1-2 used four times
    fan.triangles.insert(fan.triangles.end(), {1, 2, 3, 2, 1, 3});
    for (const Mesh* x : {&m, &open, &flipped, &twice, &degenerate, &two, &bad_index, &ragged, &fan})
        CHECK(is_closed_and_oriented(*x) == mesh_topology_report(*x).closed_and_oriented());
    CHECK(is_closed_and_oriented(two));
    CHECK_FALSE(is_closed_and_oriented(fan));
}

TEST_CASE("uniform blocks of random fields give closed oriented meshes", "[mesh]") {
    int fields = 0;
    for (int cs : {2, 4, 6}) {
        for (std::uint8_t level : {std::uint8_t(3), std::uint8_t(2)}) {
            for (int seed = 0; seed < 100; ++seed) {
                std::mt19937 rng(std::uint32_t(seed * 131 + cs * 7 + level));
                const glm::ivec3 dims(1 + int(rng() % 3), 1 + int(rng() % 3), 1 + int(rng() % 3));
                const glm::ivec3 off(int(rng() % 3), int(rng() % 3), int(rng() % 3));
                const LatticeFrame frame{glm::vec3(0.5f, -1.0f, 2.0f), 0.25f, cs, {}};
                const auto cells = test::block_cells(dims, off, level);
                const bool ints = seed % 2 == 0;  // small integers: many exact zeros
                std::uniform_real_distribution<float> real(-1.0f, 1.0f);
                const glm::ivec3 lo = off * cs, hi = (off + dims) * cs;
                auto field = test::make_field(cells, frame, [&](glm::ivec3 p) {
                    if (test::on_box_boundary(p, lo, hi)) return 1.0f;
                    return ints ? float(int(rng() % 5) - 2) : real(rng);
                });
                const Mesh m = mesh_of(cells, frame, field);
                INFO("cs " << cs << " level " << int(level) << " seed " << seed);
                const auto r = mesh_topology_report(m);
                INFO("boundary " << r.boundary_edges << " conflicts " << r.orientation_conflicts << " non-manifold "
                                 << r.non_manifold_edges << " degenerate " << r.degenerate_triangles);
                CHECK(r.closed_and_oriented());
                CHECK(is_closed_and_oriented(m));
                if (m.triangle_count() > 1) {  // one triangle dropped, one turned over, one repeated: both verdicts false
                    const std::size_t k = 3 * (rng() % m.triangle_count());
                    Mesh dropped = m, turned = m, repeated = m;
                    dropped.triangles.erase(dropped.triangles.begin() + std::ptrdiff_t(k), dropped.triangles.begin() + std::ptrdiff_t(k + 3));
                    std::swap(turned.triangles[k], turned.triangles[k + 1]);
                    repeated.triangles.insert(repeated.triangles.end(), m.triangles.begin() + std::ptrdiff_t(k),
                                              m.triangles.begin() + std::ptrdiff_t(k + 3));
                    for (const Mesh* x : {&dropped, &turned, &repeated}) {
                        CHECK_FALSE(is_closed_and_oriented(*x));
                        CHECK_FALSE(mesh_topology_report(*x).closed_and_oriented());
                    }
                }
                CHECK(m.vertex_level.size() == m.vertex_count());
                CHECK(m.triangle_kind.size() == m.triangle_count());
                CHECK(std::count(m.triangle_kind.begin(), m.triangle_kind.end(), TriangleKind::Patch) == 0);
                ++fields;
            }
        }
    }
    CHECK(fields == 600);
}

namespace {

struct SphereSetup {
    LatticeFrame frame;
    std::vector<CoarseCell> cells;
    FinePointMap field;
    double radius;
    glm::dvec3 centre;
};

// Cells whose box meets the sphere |x - c| = R (lattice units), all at `level`.
SphereSetup sphere_setup(double radius, int cs, std::uint8_t level) {
    SphereSetup s;
    s.frame = {glm::vec3(-3.0f, 1.0f, 0.5f), 0.5f, cs, {}};
    s.radius = radius;
    const int nc = int(std::ceil((2 * radius + 4) / cs)) + 2;
    const glm::dvec3 centre(nc * cs / 2.0 + 0.3, nc * cs / 2.0 - 0.2, nc * cs / 2.0 + 0.1);
    s.centre = centre;
    for (int z = 0; z < nc; ++z)
        for (int y = 0; y < nc; ++y)
            for (int x = 0; x < nc; ++x) {
                const glm::dvec3 lo = glm::dvec3(x, y, z) * double(cs), hi = lo + double(cs);
                const glm::dvec3 near = glm::clamp(centre, lo, hi);
                glm::dvec3 far;
                for (int k = 0; k < 3; ++k) far[k] = std::abs(centre[k] - lo[k]) > std::abs(centre[k] - hi[k]) ? lo[k] : hi[k];
                if (glm::length(near - centre) <= radius && glm::length(far - centre) >= radius)
                    s.cells.push_back({{x, y, z}, level});
            }
    s.field = test::make_field(s.cells, s.frame, [&](glm::ivec3 p) {
        return float(glm::length(glm::dvec3(p) - centre) - radius);
    });
    return s;
}

}  // namespace

TEST_CASE("sphere: closed, outward, volume within 2% of the ball", "[mesh]") {
    for (std::uint8_t level : {std::uint8_t(3), std::uint8_t(2)}) {
        SphereSetup s = sphere_setup(12.0, 4, level);
        const Mesh m = triangulate_cells(s.cells, s.frame, s.field);
        INFO("level " << int(level) << ", " << m.triangle_count() << " triangles");
        CHECK(is_closed_and_oriented(m));
        const double r_world = s.radius * s.frame.step;
        const double ball = 4.0 / 3.0 * M_PI * r_world * r_world * r_world;
        const double vol = test::signed_volume(m);
        CHECK(vol > 0.0);
        CHECK(std::abs(vol - ball) / ball < 0.02);
        for (std::uint8_t l : m.vertex_level) CHECK(l == level);
    }
}

TEST_CASE("level-2 sphere with true values at crossed edge midpoints (edge refinement)", "[mesh]") {
    SphereSetup s = sphere_setup(12.0, 4, 2);
    const Mesh plain = triangulate_cells(s.cells, s.frame, s.field);
    const glm::dvec3 centre = s.centre;
    for (std::uint64_t key : edge_refinement_points(s.cells, s.frame, s.field))
        s.field.insert(key, float(glm::length(glm::dvec3(lattice::unpack(key)) - centre) - s.radius));
    const Mesh refined = triangulate_cells(s.cells, s.frame, s.field);
    CHECK(is_closed_and_oriented(refined));
    CHECK(refined.triangle_count() == plain.triangle_count());
    // Every vertex now lies within a small distance of the sphere: the linear fit on a unit sub-edge.
    double worst_plain = 0, worst_refined = 0;
    auto worst = [&](const Mesh& m) {
        double w = 0;
        for (std::size_t v = 0; v < m.vertex_count(); ++v) {
            const glm::dvec3 p((m.positions[3 * v] - s.frame.origin.x) / s.frame.step,
                               (m.positions[3 * v + 1] - s.frame.origin.y) / s.frame.step,
                               (m.positions[3 * v + 2] - s.frame.origin.z) / s.frame.step);
            w = std::max(w, std::abs(glm::length(p - centre) - s.radius));
        }
        return w;
    };
    worst_plain = worst(plain);
    worst_refined = worst(refined);
    INFO("worst vertex distance to the sphere, lattice steps: " << worst_plain << " -> " << worst_refined);
    CHECK(worst_refined < worst_plain);
    CHECK(worst_refined < 0.05);
}

TEST_CASE("the crossed level-2 midpoints: every crossed edge of every level-2 cell, once, unless held", "[mesh]") {
    // Three level-2 cells around the line x = 8, y = 4 (cs = 4), a plane at z = 5.3: it crosses
    // the z edges from z = 4 to 6 at every even (x, y) of the cells' footprint, 21 columns.
    SphereSetup s;
    s.frame = {glm::vec3(0.0f), 0.5f, 4, {}};
    s.cells = {{{2, 0, 1}, 2}, {{1, 1, 1}, 2}, {{2, 1, 1}, 2}};
    s.field = test::make_field(s.cells, s.frame, [](glm::ivec3 p) { return float(p.z) - 5.3f; });
    std::vector<std::uint64_t> keys = edge_refinement_points(s.cells, s.frame, s.field);
    CHECK(keys.size() == 21);
    CHECK(std::is_sorted(keys.begin(), keys.end()));
    CHECK(std::adjacent_find(keys.begin(), keys.end()) == keys.end());
    for (std::uint64_t k : keys) {
        const glm::ivec3 p = lattice::unpack(k);
        CHECK((p.z == 5 && p.x % 2 == 0 && p.y % 2 == 0));
    }
    s.field.insert(keys[3], 0.25f);  // held already (a level-3 cell's point): not listed
    CHECK(edge_refinement_points(s.cells, s.frame, s.field).size() == 20);
    s.cells[1].level = 3;  // level-3 cells list none
    CHECK(edge_refinement_points(s.cells, s.frame, s.field).size() < 20);
}

TEST_CASE("vertex positions keep float's resolution where lattice coordinates are large", "[mesh][precision]") {
    // The same field and the same world positions twice: lattice block at coarse cell 0, and at
    // coarse cell 32768 (lattice coordinate 131072 = 2^17) with the origin moved back by as many
    // steps, so the world point of every lattice point is the same real number. A vertex is
    // origin + step * (lower + t) rounded once to float: both placements must agree to within one
    // float spacing at the vertex (each is within half of it). Rounding lower + t to float first
    // would keep t only to 2^-6 of a step there (2^17 has 17 of float's 24 bits).
    const float step = 0.025f;
    const int shift = 131072;
    const glm::vec3 near_origin(0.25f, 0.5f, 0.75f);
    glm::vec3 far_origin;
    for (int k = 0; k < 3; ++k) {
        const double o = double(near_origin[k]) - double(step) * shift;
        far_origin[k] = float(o);
        REQUIRE(double(far_origin[k]) == o);  // exact: the two frames put every lattice point at one place
    }
    for (std::uint8_t level : {std::uint8_t(3), std::uint8_t(2)}) {
        auto mesh_at = [&](glm::vec3 origin, glm::ivec3 offset) {
            const LatticeFrame frame{origin, step, 4, {}};
            const std::vector<CoarseCell> cells = test::block_cells(glm::ivec3(4), offset, level);
            const glm::dvec3 centre = glm::dvec3(offset * 4) + glm::dvec3(8.3, 7.9, 8.1);
            const FinePointMap field = test::make_field(cells, frame, [&](glm::ivec3 p) {
                return float(glm::length(glm::dvec3(p) - centre) - 5.7);
            });
            return triangulate_cells(cells, frame, field);
        };
        const Mesh a = mesh_at(near_origin, glm::ivec3(0)), b = mesh_at(far_origin, glm::ivec3(shift / 4));
        INFO("level " << int(level) << ", " << a.vertex_count() << " vertices");
        REQUIRE(is_closed_and_oriented(a));
        REQUIRE(a.triangles == b.triangles);
        REQUIRE(a.positions.size() == b.positions.size());
        double worst = 0.0;  // in float spacings at the vertex
        for (std::size_t i = 0; i < a.positions.size(); ++i) {
            const float x = a.positions[i];
            const double spacing = double(std::nextafter(std::fabs(x), INFINITY)) - double(std::fabs(x));
            worst = std::max(worst, std::fabs(double(b.positions[i]) - double(x)) / spacing);
        }
        INFO("largest difference " << worst << " float spacings");
        CHECK(worst <= 1.0);
    }
}

TEST_CASE("triangulation is bit-identical for 1 and 2 threads", "[mesh]") {
    SphereSetup s = sphere_setup(20.0, 4, 3);
    auto run = [&](int threads) {
        tbb::task_arena arena(threads);
        Mesh m;
        arena.execute([&] { m = triangulate_cells(s.cells, s.frame, s.field); });
        return m;
    };
    const Mesh a = run(1), b = run(2);
    CHECK(a.positions == b.positions);
    CHECK(a.triangles == b.triangles);
    CHECK(a.vertex_level == b.vertex_level);
    CHECK(a.triangle_kind == b.triangle_kind);
    CHECK(a.triangle_count() > 1000);
}

TEST_CASE("triangulation speed on a uniform sphere of ~1M triangles", "[.][mesh-bench]") {
    SphereSetup s = sphere_setup(200.0, 4, 3);
    for (int threads : {1, 2}) {
        tbb::global_control gc(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
        Mesh m;
        double best = 1e9;
        for (int rep = 0; rep < 3; ++rep) {
            const auto t0 = std::chrono::steady_clock::now();
            m = triangulate_cells(s.cells, s.frame, s.field);
            best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        }
        const auto t0 = std::chrono::steady_clock::now();
        const bool closed = is_closed_and_oriented(m);
        const double check_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        WARN(threads << " threads: " << s.cells.size() << " cells, " << m.triangle_count() << " triangles in "
                     << best * 1e3 << " ms = " << m.triangle_count() / best / 1e6 << " M triangles/s; closed check "
                     << check_s * 1e3 << " ms, closed " << closed);
        CHECK(closed);
    }
}
