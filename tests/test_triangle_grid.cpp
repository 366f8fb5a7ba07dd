// The triangle grid of the crossing check (host/triangle_grid.hpp) against brute force: every
// triangle whose box overlaps a query box is reported, none twice, also after triangles are
// relisted with new corners, on meshes of even and of wildly mixed triangle sizes ([mesh]).
#include <map>
#include <random>

#include <glm/glm.hpp>

#include "test_support.hpp"
#include "triangle_grid.hpp"

using namespace trilevel;

namespace {

struct Soup {
    Mesh mesh;
    std::vector<std::uint8_t> dead;
};

// n triangles with corners near random centres; `spread`: the largest extent against the box.
Soup random_soup(unsigned seed, std::size_t n, float spread) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    Soup s;
    for (std::size_t t = 0; t < n; ++t) {
        const glm::vec3 centre(unit(rng), unit(rng), unit(rng));
        const float size = t % 97 == 0 ? spread : 0.02f * unit(rng);
        for (int k = 0; k < 3; ++k) {
            const glm::vec3 p = centre + size * glm::vec3(unit(rng), unit(rng), unit(rng));
            s.mesh.positions.insert(s.mesh.positions.end(), {p.x, p.y, p.z});
            s.mesh.triangles.push_back(std::uint32_t(3 * t + k));
        }
        s.dead.push_back(t % 13 == 5);
    }
    return s;
}

void box_of(const Mesh& m, std::uint32_t t, glm::dvec3& lo, glm::dvec3& hi) {
    for (int k = 0; k < 3; ++k) {
        const std::uint32_t v = m.triangles[3 * t + k];
        const glm::dvec3 p(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]);
        lo = k ? glm::min(lo, p) : p;
        hi = k ? glm::max(hi, p) : p;
    }
}

// Every query (boxes around the unit cube at `at`): the reported triangles hold each overlapping
// live one, once, and no dead one.
void check_queries(TriangleGrid& grid, const Soup& s, std::mt19937& rng, TriangleGrid::Local& local,
                   glm::dvec3 at = glm::dvec3(0.0)) {
    std::uniform_real_distribution<double> unit(-0.1, 1.1);
    for (int q = 0; q < 200; ++q) {
        glm::dvec3 a = at + glm::dvec3(unit(rng), unit(rng), unit(rng)), b = a + 0.05 * glm::dvec3(unit(rng), unit(rng), unit(rng));
        const glm::dvec3 lo = glm::min(a, b), hi = glm::max(a, b);
        std::map<std::uint32_t, int> seen;
        grid.for_each_near(lo, hi, local, [&](std::uint32_t t) { ++seen[t]; });
        for (auto [t, n] : seen) {
            REQUIRE(n == 1);
            REQUIRE(s.dead[t] == 0);
        }
        for (std::uint32_t t = 0; t < s.mesh.triangle_count(); ++t) {
            if (s.dead[t]) continue;
            glm::dvec3 tlo, thi;
            box_of(s.mesh, t, tlo, thi);
            const bool overlaps = !glm::any(glm::lessThan(thi, lo)) && !glm::any(glm::greaterThan(tlo, hi));
            if (overlaps) REQUIRE(seen.count(t) == 1);
        }
    }
}

}  // namespace

TEST_CASE("triangle grid finds every triangle overlapping a box, once, also after relisting", "[mesh]") {
    // 0.02: even sizes; 0.6: a few triangles across half the box, so cells are large; 1e4: a
    // splayed mesh whose grid at the largest extent is too coarse (one cell), also fine.
    for (float spread : {0.02f, 0.6f, 1e4f}) {
        Soup s = random_soup(7u + unsigned(spread), 3000, spread);
        TriangleGrid grid(s.mesh, s.dead);
        std::mt19937 rng(11);
        TriangleGrid::Local local, scratch;  // a thread's relists; a query's scratch alone
        check_queries(grid, s, rng, scratch);
        // Move corners of some triangles (as a collapse does: onto another vertex's position) and
        // relist them, some twice: in the grid's own lists, then in a thread's Local (seen by
        // queries with that Local), then adopted into the grid's.
        std::uniform_int_distribution<std::uint32_t> pick(0, std::uint32_t(s.mesh.triangle_count() - 1));
        auto move_some = [&](TriangleGrid::Local* into) {
            for (int i = 0; i < 300; ++i) {
                const std::uint32_t t = pick(rng), other = pick(rng);
                if (s.dead[t]) continue;
                const std::uint32_t was = s.mesh.triangles[3 * t];
                s.mesh.triangles[3 * t] = s.mesh.triangles[3 * other + 1];
                glm::dvec3 lo, hi;
                box_of(s.mesh, t, lo, hi);
                if (into && glm::any(glm::greaterThan(hi - lo, glm::dvec3(grid.reach())))) {  // a Local's keep within reach
                    s.mesh.triangles[3 * t] = was;
                    continue;
                }
                grid.relist(t, lo, hi, into);
            }
        };
        for (int round = 0; round < 2; ++round) move_some(nullptr);
        check_queries(grid, s, rng, scratch);
        move_some(&local);
        check_queries(grid, s, rng, local);
        grid.adopt(local);
        check_queries(grid, s, rng, scratch);
        check_queries(grid, s, rng, local);  // emptied, and clean for its next use
    }
}

TEST_CASE("triangle grid of two clusters far apart keeps cells near its largest triangle", "[mesh]") {
    // A frame of two far-apart groups (a split domain) is such a mesh. Cells grown until the grid
    // over the whole box fitted were a cluster wide there: each query read most of a cluster, and
    // the sliver cleanup of two clusters 40 units apart took 127 s (each alone 0.5 s). The grid now
    // grows its cells three times at most and then wraps around (cells far apart share a slot).
    Soup s = random_soup(3, 3000, 0.02f);
    const glm::dvec3 far(1e4, -2e4, 3e4);
    Soup b = random_soup(4, 3000, 0.02f);
    const auto first = std::uint32_t(s.mesh.vertex_count());
    for (std::size_t v = 0; v < b.mesh.vertex_count(); ++v)
        for (int k = 0; k < 3; ++k) s.mesh.positions.push_back(float(b.mesh.positions[3 * v + k] + far[k]));
    for (std::uint32_t v : b.mesh.triangles) s.mesh.triangles.push_back(first + v);
    s.dead.insert(s.dead.end(), b.dead.begin(), b.dead.end());
    TriangleGrid grid(s.mesh, s.dead);
    CHECK(grid.cell_side() < 0.07);  // grown 3 times at most: 3.375 times the largest extent (0.02), not 219 units
    std::mt19937 rng(5);
    TriangleGrid::Local local;
    check_queries(grid, s, rng, local);
    check_queries(grid, s, rng, local, far);
    // Relisted near one cluster: found there, and never reported by queries at the other.
    for (std::uint32_t t = 0; t < 3000; t += 7) {
        if (s.dead[t]) continue;
        glm::dvec3 lo, hi;
        box_of(s.mesh, t, lo, hi);
        grid.relist(t, lo, hi, &local);
    }
    check_queries(grid, s, rng, local);
    check_queries(grid, s, rng, local, far);
}
