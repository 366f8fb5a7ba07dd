// The level-2 check (host/level2_check.hpp): which level-2 cells it sends to level 3 ([mesh]), and
// the whole pipeline with it on ([e2e]).
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "cli_test_support.hpp"
#include "level2_check.hpp"
#include "mesh_test_support.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"
#include "trilevel/trilevel.hpp"

using namespace trilevel;

namespace {

const LatticeFrame kFrame{glm::vec3(0.0f), 1.0f, 4, {}};

/// A row of five level-2 cells along x at y = z = 5, then a level-3 cell, and a level-2 cell two
/// rows away in y (outside every 3x3x3 block of the row's middle cell).
std::vector<CoarseCell> row_cells() {
    std::vector<CoarseCell> cells;
    for (int x = 3; x <= 7; ++x) cells.push_back({{x, 5, 5}, 2});
    cells.push_back({{8, 5, 5}, 3});
    cells.push_back({{5, 7, 5}, 2});
    return cells;
}

/// Every cell checked.
std::vector<std::uint8_t> all(const std::vector<CoarseCell>& cells) { return std::vector<std::uint8_t>(cells.size(), 1); }

/// The field of `cells` from f, with the centres of the level-2 cubes (odd coordinates) added.
FinePointMap field_with_centres(const std::vector<CoarseCell>& cells, const std::function<float(glm::ivec3)>& f) {
    FinePointMap map = test::make_field(cells, kFrame, f);
    for (const CoarseCell& c : cells)
        for (int z = 1; z < 4 && c.level == 2; z += 2)
            for (int y = 1; y < 4; y += 2)
                for (int x = 1; x < 4; x += 2) {
                    const glm::ivec3 p = c.coord * 4 + glm::ivec3(x, y, z);
                    map.insert(lattice::pack(p), f(p));
                }
    return map;
}

}  // namespace

TEST_CASE("level-2 check: a linear field passes, a bump promotes its cell alone, unchecked cells never", "[mesh]") {
    const auto cells = row_cells();
    auto plane = [](glm::ivec3 p) { return float(p.z) - 21.3f; };  // crosses every cell at z = 21.3
    // Trilinear interpolation reproduces a linear field: no cell fails, whatever the tolerance.
    CHECK(cells_failing_level2_check(cells, all(cells), kFrame, field_with_centres(cells, plane), 1e-4f).empty());

    // The centre (21, 21, 21) of a crossed cube of cell (5, 5, 5) sits 0.8 off the plane's value.
    const glm::ivec3 bump(21, 21, 21);
    auto bumped = [&](glm::ivec3 p) { return plane(p) + (p == bump ? -0.8f : 0.0f); };
    const FinePointMap field = field_with_centres(cells, bumped);
    const auto promoted = cells_failing_level2_check(cells, all(cells), kFrame, field, 0.5f);
    REQUIRE(promoted.size() == 1);  // (5,5,5) alone, not its level-2 neighbours (4,5,5), (6,5,5)
    CHECK(cells[promoted[0]].coord == glm::ivec3(5, 5, 5));
    // A tolerance above the gap promotes nothing.
    CHECK(cells_failing_level2_check(cells, all(cells), kFrame, field, 0.9f).empty());
    // Nor does the check where it is not asked (the cell's curvature says flat).
    std::vector<std::uint8_t> checked = all(cells);
    checked[2] = 0;  // (5,5,5)
    CHECK(cells_failing_level2_check(cells, checked, kFrame, field, 0.5f).empty());
}

TEST_CASE("level-2 check: cubes the surface does not cross are never promoted, missing points are errors", "[mesh]") {
    const auto cells = row_cells();
    // All positive (air), with a large gap at one centre: no surface there to misplace.
    const glm::ivec3 bump(21, 21, 21);
    auto air = [&](glm::ivec3 p) { return 5.0f + (p == bump ? 3.0f : 0.0f); };
    CHECK(cells_failing_level2_check(cells, all(cells), kFrame, field_with_centres(cells, air), 0.5f).empty());
    // A centre the surface reaches only there (the corners all outside): crossed, promoted.
    auto droplet = [&](glm::ivec3 p) { return p == bump ? -1.0f : 1.0f; };
    CHECK(cells_failing_level2_check(cells, all(cells), kFrame, field_with_centres(cells, droplet), 0.5f).size() == 1);
    // Without the centres the check cannot run.
    const FinePointMap no_centres = test::make_field(cells, kFrame, droplet);
    CHECK_THROWS_AS(cells_failing_level2_check(cells, all(cells), kFrame, no_centres, 0.5f), Error);
}

TEST_CASE("level-2 check end to end: closed, deterministic, more level-3 cells, on by default", "[e2e]") {
    const float r = 0.025f;
    const ParticleSet s = generate_scene("pool-and-drop", r, 1);
    Reconstructor rec;
    Params p;
    p.particle_radius = r;
    CHECK(p.level2_tolerance > 0.0f);  // the default checks
    Stats off, on, again;
    p.level2_tolerance = 0.0f;
    const Mesh m_off = rec.reconstruct(s.positions.data(), s.size(), p, &off);
    p.level2_tolerance = 0.1f;  // tight, so that this scene's few non-flat cells fail
    const Mesh m_on = rec.reconstruct(s.positions.data(), s.size(), p, &on);
    const Mesh m_again = rec.reconstruct(s.positions.data(), s.size(), p, &again);
    INFO("level-2 cells promoted: " << on.level2_check_cells);
    CHECK(off.level2_check_cells == 0);
    CHECK(on.level2_check_cells > 0);
    CHECK(on.surface_cells_level3 >= off.surface_cells_level3 + on.level2_check_cells);
    CHECK(is_closed_and_oriented(m_on));
    CHECK(on.closed);
    CHECK(test::same_mesh(m_on, m_again));
    CHECK(!test::same_mesh(m_on, m_off));
    CHECK(std::count(m_on.vertex_level.begin(), m_on.vertex_level.end(), 3) >
          std::count(m_off.vertex_level.begin(), m_off.vertex_level.end(), 3));

    for (float bad : {-0.5f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
        p.level2_tolerance = bad;
        CHECK_THROWS_WITH(rec.reconstruct(s.positions.data(), s.size(), p),
                          Catch::Matchers::Contains("level-2 tolerance must be finite and >= 0"));
    }
}

TEST_CASE("CLI --level2-tolerance: the library's mesh, and its promotions in --stats", "[cli]") {
    const float r = 0.025f;
    test::TempDir tmp;
    const ParticleSet s = generate_scene("pool-and-drop", r, 1);
    write_particles(tmp.file("s.xyz"), s);
    const auto run = test::run_cli(tmp, "reconstruct '" + tmp.file("s.xyz") + "' -r 0.025 --level2-tolerance 0.5 -o '" +
                                            tmp.file("m.ply") + "' --stats '" + tmp.file("m.json") + "'");
    INFO(run.err);
    REQUIRE(run.code == 0);
    Params p;
    p.particle_radius = r;
    p.level2_tolerance = 0.5f;
    Stats st;
    const Mesh expected = Reconstructor().reconstruct(s.positions.data(), s.size(), p, &st);
    const Mesh m = read_mesh(tmp.file("m.ply"));
    CHECK(m.positions == expected.positions);
    CHECK(m.triangles == expected.triangles);
    const std::string json = test::slurp(tmp.file("m.json"));
    CHECK(json.find("\"level2_check_cells\": " + std::to_string(st.level2_check_cells)) != std::string::npos);
    CHECK(json.find("\"level2_tolerance\": 0.5") != std::string::npos);
}

namespace {

/// The points of a 2r lattice (origin `shift`, moved by up to `jitter` per axis, seeded) that lie
/// inside the body whose signed distance, in world units, is `sd`; the lattice spans `half` about
/// the origin.
std::vector<float> fill(float r, glm::vec3 half, glm::vec3 shift, float jitter, std::uint32_t seed,
                        const std::function<float(glm::vec3)>& sd) {
    const glm::ivec3 n = glm::ivec3(glm::ceil(half / r)) + 1;
    std::vector<float> x;
    for (const glm::vec3& p : test::lattice_points(n, shift - 2.0f * r * glm::vec3(n / 2), 2.0f * r, jitter, seed))
        if (sd(p) <= 0.0f) x.insert(x.end(), {p.x, p.y, p.z});
    return x;
}

}  // namespace

TEST_CASE("thin rods and tori keep the volume uniform r gives them", "[level2][e2e]") {
    // A rod and a torus of radius 2r, one torus jittered a quarter spacing, each on eight lattice
    // shifts. Their cells' curvature is about 2.5-3, under the check's gate: they kept 0.938 of
    // uniform r's volume on average (0.81 at worst). As thin bodies (no particle inside the fluid
    // near them, constants::kThinBodyTolerance) they are checked at a tighter tolerance.
    const float r = 0.025f;
    const auto rod = [r](glm::vec3 p) {  // 120r long, along x
        return std::max(std::hypot(p.y, p.z) - 2.0f * r, std::abs(p.x) - 60.0f * r);
    };
    const auto torus = [r](glm::vec3 p) {  // major radius 20r, about z
        return std::hypot(std::hypot(p.x, p.y) - 20.0f * r, p.z) - 2.0f * r;
    };
    Reconstructor rec;
    Params adaptive;
    adaptive.particle_radius = r;
    Params uniform = adaptive;
    uniform.mode = Mode::Uniform;
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> offset(0.0f, 2.0f * r);
    double sum = 0.0, worst = 1.0;
    int bodies = 0;
    for (std::uint32_t k = 0; k < 8; ++k) {
        const glm::vec3 shift(offset(rng), offset(rng), offset(rng));
        const std::vector<float> xs[] = {fill(r, {62 * r, 4 * r, 4 * r}, shift, 0.5f * r, 7 + k, rod),
                                         fill(r, {24 * r, 24 * r, 4 * r}, shift, 0.1f * r, 3 + k, torus),
                                         fill(r, {24 * r, 24 * r, 4 * r}, shift, 0.5f * r, 5 + k, torus)};
        for (const std::vector<float>& x : xs) {
            const std::size_t n = x.size() / 3;
            const Mesh a = rec.reconstruct(x.data(), n, adaptive);
            const Mesh u = rec.reconstruct(x.data(), n, uniform);
            test::require_closed(a, "thin body");
            const double ratio = test::signed_volume(a) / test::signed_volume(u);
            INFO("shift " << k << ", " << n << " particles: adaptive / uniform r volume " << ratio);
            CHECK(ratio < 1.01);
            sum += ratio;
            worst = std::min(worst, ratio);
            ++bodies;
        }
    }
    INFO("mean " << sum / bodies << ", worst " << worst);
    CHECK(sum / bodies > 0.985);
    CHECK(worst > 0.96);
}
