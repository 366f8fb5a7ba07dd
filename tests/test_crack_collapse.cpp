// Crack closing by collapse (host/crack_collapse.hpp): the merge itself on small closed meshes,
// and the link-condition, fold and crossing guards that refuse it ([mesh]).
#include <algorithm>

#include "crack_collapse.hpp"
#include "mesh_topology.hpp"
#include "mesh_test_support.hpp"
#include "test_support.hpp"

using namespace trilevel;

namespace {

// Octahedron, outward: vertices +x -x +y -y +z -z (0..5), triangles counter-clockwise from outside.
Mesh octahedron() {
    Mesh m;
    m.positions = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    m.triangles = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    m.vertex_level.assign(6, 3);
    m.triangle_kind.assign(8, TriangleKind::Level3);
    return m;
}

// Triangular bipyramid: equator 0, 1, 2, top 3, bottom 4.
Mesh bipyramid() {
    Mesh m;
    m.positions = {1, 0, 0, -0.5f, 0.866f, 0, -0.5f, -0.866f, 0, 0, 0, 1, 0, 0, -1};
    m.triangles = {0, 1, 3, 1, 2, 3, 2, 0, 3, 1, 0, 4, 2, 1, 4, 0, 2, 4};
    m.vertex_level.assign(5, 3);
    m.triangle_kind.assign(6, TriangleKind::Level3);
    return m;
}

}  // namespace

TEST_CASE("crack collapse merges a run's inner vertex into its end: one vertex and two triangles fewer", "[mesh]") {
    Mesh m = octahedron();
    REQUIRE(is_closed_and_oriented(m));
    // Run (+y, +x, -y): +x is the inner vertex, nearer to neither end; the first end is tried first.
    const CrackRuns runs = {3, 2, 0, 3};
    CHECK(collapse_crack_runs(m, runs) == 1);
    CHECK(m.vertex_count() == 5);
    CHECK(m.triangle_count() == 6);
    CHECK(m.triangle_kind.size() == 6);
    CHECK(m.vertex_level.size() == 5);
    CHECK(is_closed_and_oriented(m));
    // +x is gone, the others keep their order: -x, +y, -y, +z, -z.
    CHECK(m.positions == std::vector<float>{-1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1});
    CHECK(test::signed_volume(m) > 0.0);
}

TEST_CASE("crack collapse refuses a merge that breaks the link condition or folds a triangle", "[mesh]") {
    SECTION("a neighbour shared off the edge") {
        Mesh m = bipyramid(), before = m;
        CHECK(collapse_crack_runs(m, {3, 0, 1, 2}) == 0);  // 0 and 1 share 2, 3 and 4; the edge's apexes are 3, 4
        CHECK(m.triangles == before.triangles);
        CHECK(m.positions == before.positions);
    }
    SECTION("a tetrahedron") {
        Mesh m;
        m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
        m.triangles = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
        m.vertex_level.assign(4, 3);
        m.triangle_kind.assign(4, TriangleKind::Patch);
        REQUIRE(is_closed_and_oriented(m));
        CHECK(collapse_crack_runs(m, {3, 0, 1, 2}) == 0);
        CHECK(m.triangle_count() == 4);
    }
    SECTION("a triangle turned over") {
        Mesh m = octahedron();
        // +y and -y moved beyond -x: +x moved onto either of them turns a triangle of the other's
        // side over ((-y, +x, +z) resp. (+x, +y, +z)), so neither end may take it.
        m.positions[6] = -1.5f, m.positions[7] = 0.1f;
        m.positions[9] = -1.5f, m.positions[10] = -0.1f;
        const Mesh before = m;
        CHECK(collapse_crack_runs(m, {3, 2, 0, 3}) == 0);
        CHECK(m.triangles == before.triangles);
    }
    SECTION("a triangle moved through another one") {
        // A small tetrahedron inside the octahedron, across the plane x = 0: +x moved onto +y (or
        // -y) brings triangle (-y, +x, +z) (or (+x, +y, +z)) to (-y, +y, +z) in that plane, through
        // the tetrahedron. Link condition and orientation allow it; the crossing check does not.
        Mesh m = octahedron();
        const float lo[3] = {-0.1f, -0.1f, 0.25f};
        for (int c = 0; c < 4; ++c)
            for (int k = 0; k < 3; ++k) m.positions.push_back(lo[k] + (c == k + 1 ? 0.2f : 0.0f));
        for (std::uint32_t i : {0u, 2u, 1u, 0u, 1u, 3u, 0u, 3u, 2u, 1u, 2u, 3u}) m.triangles.push_back(6 + i);
        m.vertex_level.assign(10, 3);
        m.triangle_kind.assign(12, TriangleKind::Level3);
        REQUIRE(is_closed_and_oriented(m));
        REQUIRE(test::self_intersections(m) == 0);
        const Mesh before = m;
        CHECK(collapse_crack_runs(m, {3, 2, 0, 3}) == 0);
        CHECK(m.triangles == before.triangles);
        // Without the tetrahedron the same run collapses.
        Mesh alone = octahedron();
        CHECK(collapse_crack_runs(alone, {3, 2, 0, 3}) == 1);
    }
}

TEST_CASE("crack collapse keeps the surviving patches' kind and every other triangle's", "[mesh]") {
    Mesh m = octahedron();
    m.triangle_kind = {TriangleKind::Patch, TriangleKind::Level2, TriangleKind::Level2, TriangleKind::Patch,
                       TriangleKind::Level3, TriangleKind::Level2, TriangleKind::Level2, TriangleKind::Level3};
    // +x into +y: triangles 0 (+x +y +z) and 4 (+y +x -z) die; 3 (-y +x +z) and 7 (+x -y -z) take +y.
    CHECK(collapse_crack_runs(m, {3, 2, 0, 3}) == 1);
    CHECK(m.triangle_kind == std::vector<TriangleKind>{TriangleKind::Level2, TriangleKind::Level2, TriangleKind::Patch,
                                                       TriangleKind::Level2, TriangleKind::Level2, TriangleKind::Level3});
    CHECK(std::count(m.triangles.begin(), m.triangles.end(), 1u) == 4);  // +y (now 1) in 4 triangles, as +x was
}
