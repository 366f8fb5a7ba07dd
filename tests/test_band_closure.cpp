// Band closure and transition continuity (docs/design.md §7) ([mesh]).
#include <algorithm>
#include <cmath>
#include <random>

#include "band_closure.hpp"
#include "core/cell_index.hpp"
#include "marching_cubes.hpp"
#include "mesh_test_support.hpp"
#include "surface_mesher.hpp"
#include "test_support.hpp"
#include "transition_continuity.hpp"

using namespace trilevel;

namespace {

// Adds every point of `cells` at its stride that `map` lacks.
void add_points(FinePointMap& map, const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                const std::function<float(glm::ivec3)>& f) {
    const int cs = frame.coarse_steps;
    for (const CoarseCell& c : cells)
        for (int z = 0; z <= cs; z += stride(c.level))
            for (int y = 0; y <= cs; y += stride(c.level))
                for (int x = 0; x <= cs; x += stride(c.level)) {
                    const glm::ivec3 p = c.coord * cs + glm::ivec3(x, y, z);
                    if (!map.find(p)) map.insert(lattice::pack(p), f(p));
                }
}

bool by_key(const CoarseCell& a, const CoarseCell& b) { return lattice::pack(a.coord) < lattice::pack(b.coord); }

}  // namespace

TEST_CASE("band closure: a plane through one cell asks for its four side neighbours", "[mesh]") {
    const LatticeFrame frame{glm::vec3(0.0f), 1.0f, 4, {}};
    for (std::uint8_t level : {std::uint8_t(2), std::uint8_t(3)}) {
        const std::vector<CoarseCell> cells = {{{5, 5, 5}, level}};
        const auto field = test::make_field(cells, frame, [](glm::ivec3 p) { return float(p.z) - 21.5f; });
        const auto added = band_closure_cells(cells, frame, field);
        REQUIRE(added.size() == 4);
        CHECK(std::is_sorted(added.begin(), added.end(), by_key));
        for (const CoarseCell& c : added) {
            CHECK(c.level == level);
            CHECK(c.coord.z == 5);
            CHECK(std::abs(c.coord.x - 5) + std::abs(c.coord.y - 5) == 1);
        }
    }
}

TEST_CASE("band closure: largest triggering level, present cells skipped, domain error", "[mesh]") {
    const LatticeFrame frame{glm::vec3(0.0f), 1.0f, 4, {}};
    // Two cells with a gap along x, both crossed by a plane z = const: (4,3,3) is asked for by both.
    const std::vector<CoarseCell> cells = {{{3, 3, 3}, 2}, {{5, 3, 3}, 3}};
    const auto field = test::make_field(cells, frame, [](glm::ivec3 p) { return float(p.z) - 13.5f; });
    const auto added = band_closure_cells(cells, frame, field);
    CHECK(added.size() == 7);
    CHECK(std::is_sorted(added.begin(), added.end(), by_key));
    for (const CoarseCell& c : added) {
        CHECK(c.coord.z == 3);
        CHECK(c.level == (c.coord.x <= 3 ? 2 : 3));
    }
    // With (4,3,3) present, it is not asked for again.
    std::vector<CoarseCell> three = cells;
    three.insert(three.begin() + 1, CoarseCell{{4, 3, 3}, 3});
    const auto f3 = test::make_field(three, frame, [](glm::ivec3 p) { return float(p.z) - 13.5f; });
    const auto added3 = band_closure_cells(three, frame, f3);
    CHECK(added3.size() == 8);
    for (const CoarseCell& c : added3) CHECK(c.coord != glm::ivec3(4, 3, 3));
    // A plane x = const in a cell at the domain's lower corner leaves through no face,
    // but one along y crosses the -y face at y = 0: outside the domain.
    const std::vector<CoarseCell> corner = {{{0, 0, 0}, 3}};
    const auto f2 = test::make_field(corner, frame, [](glm::ivec3 p) { return float(p.x) - 1.5f; });
    CHECK_THROWS_WITH(band_closure_cells(corner, frame, f2), Catch::Contains("domain"));
    // At the top: a neighbour whose points would pass lattice::kMaxCoord.
    const int top = lattice::kMaxCoord / frame.coarse_steps - 1;
    const std::vector<CoarseCell> high = {{{top, 2, 2}, 2}};
    const auto f_high = test::make_field(high, frame, [](glm::ivec3 p) { return float(p.y) - 9.5f; });
    CHECK_THROWS_WITH(band_closure_cells(high, frame, f_high), Catch::Contains("domain"));
    const std::vector<CoarseCell> below = {{{top - 1, 2, 2}, 2}};
    const auto f4 = test::make_field(below, frame, [](glm::ivec3 p) { return float(p.y) - 9.5f; });
    CHECK(band_closure_cells(below, frame, f4).size() == 4);
}

TEST_CASE("band closure iterated to a fixed point closes the mesh of a sphere seeded by a few cells", "[mesh]") {
    const LatticeFrame frame{glm::vec3(1.0f, 2.0f, 3.0f), 0.5f, 4, {}};
    const glm::dvec3 centre(40.3, 39.7, 40.1);
    const double radius = 13.0;
    auto f = [&](glm::ivec3 p) { return float(glm::length(glm::dvec3(p) - centre) - radius); };
    for (std::uint8_t level : {std::uint8_t(2), std::uint8_t(3)}) {
        // Seed: one cell on the surface (+x pole).
        std::vector<CoarseCell> cells = {{{13, 9, 10}, level}};
        FinePointMap field(1 << 18);
        add_points(field, cells, frame, f);
        int rounds = 0;
        for (;;) {
            const auto added = band_closure_cells(cells, frame, field);
            if (added.empty()) break;
            add_points(field, added, frame, f);
            cells.insert(cells.end(), added.begin(), added.end());
            std::sort(cells.begin(), cells.end(), by_key);
            REQUIRE(++rounds < 200);
        }
        apply_transition_continuity(cells, frame, field);
        const Mesh m = triangulate_cells(cells, frame, field);
        INFO("level " << int(level) << ": " << cells.size() << " cells after " << rounds << " rounds");
        CHECK(rounds > 3);
        CHECK(is_closed_and_oriented(m));
        const double r = radius * frame.step;
        CHECK(std::abs(test::signed_volume(m) - 4.0 / 3.0 * M_PI * r * r * r) < 0.03 * 4.0 / 3.0 * M_PI * r * r * r);
    }
}

TEST_CASE("band closure iterated on mixed levels gives closed meshes", "[mesh]") {
    const LatticeFrame frame{glm::vec3(0.0f), 1.0f, 4, {}};
    for (int seed = 0; seed < 40; ++seed) {
        std::mt19937 rng(std::uint32_t(seed) + 1000u);
        const glm::dvec3 centre(40 + (rng() % 100) / 50.0, 40 + (rng() % 100) / 50.0, 40 + (rng() % 100) / 50.0);
        const double radius = 6.0 + (rng() % 60) / 10.0;
        auto f = [&](glm::ivec3 p) {
            const glm::dvec3 d = glm::dvec3(p) - centre;
            return float(glm::length(d) - radius + 1.5 * std::sin(0.8 * d.x) * std::cos(0.6 * d.y));
        };
        auto pick_level = [&](glm::ivec3 c) { return std::uint8_t(((c.x * 7 + c.y * 3 + c.z * 5 + seed) % 3) ? 3 : 2); };
        std::vector<CoarseCell> cells;
        for (int z = 8; z < 12; ++z)
            for (int y = 8; y < 12; ++y)
                for (int x = 8; x < 12; ++x) cells.push_back({{x, y, z}, pick_level({x, y, z})});
        FinePointMap field(1 << 18);
        add_points(field, cells, frame, f);
        for (int round = 0;; ++round) {
            apply_transition_continuity(cells, frame, field);
            auto added = band_closure_cells(cells, frame, field);
            if (added.empty()) break;
            for (CoarseCell& c : added) c.level = pick_level(c.coord);
            add_points(field, added, frame, f);
            cells.insert(cells.end(), added.begin(), added.end());
            std::sort(cells.begin(), cells.end(), by_key);
            REQUIRE(round < 200);
        }
        const Mesh m = triangulate_cells(cells, frame, field);
        INFO("seed " << seed << ", " << cells.size() << " cells");
        CHECK(is_closed_and_oriented(m));
        CHECK(test::signed_volume(m) > 0.0);
    }
}

TEST_CASE("transition continuity: uncrossed midpoints interpolated, crossed ones and the rest kept, idempotent",
          "[mesh]") {
    const LatticeFrame frame{glm::vec3(0.0f), 1.0f, 4, {}};
    const std::vector<CoarseCell> cells = {{{1, 1, 1}, 2}, {{2, 1, 1}, 3}, {{2, 2, 1}, 3}, {{1, 2, 2}, 3}};
    // Level-2 points (all coordinates even) inside where x + y + z <= 21, so that some boundary
    // edges are crossed and some not; the other points random, of either sign.
    std::mt19937 rng(7);
    FinePointMap field = test::make_field(cells, frame, [&](glm::ivec3 p) {
        const float u = std::uniform_real_distribution<float>(0.1f, 1.0f)(rng);
        if ((p.x | p.y | p.z) & 1) return rng() % 2 ? u : -u;
        return p.x + p.y + p.z <= 21 ? -u : u;
    });
    const FinePointMap before = field;
    apply_transition_continuity(cells, frame, field);
    auto v = [&](int x, int y, int z) { return *field.find(glm::ivec3(x, y, z)); };
    auto was = [&](int x, int y, int z) { return *before.find(glm::ivec3(x, y, z)); };
    // Face between (1,1,1) and (2,1,1): x = 8; y, z in [4, 8].
    CHECK(v(8, 5, 4) == lattice::edge_midpoint_value(v(8, 4, 4), v(8, 6, 4)));  // sums 16, 18: uncrossed
    CHECK(v(8, 7, 6) == was(8, 7, 6));  // sums 20, 22: crossed, the field's value stays
    CHECK(v(8, 5, 7) == was(8, 5, 7));  // the centre of a level-2 square stays
    // Coarse edge shared with the diagonal neighbour (2,2,1): x = 8, y = 8, z odd.
    CHECK(v(8, 8, 5) == was(8, 8, 5));  // 20, 22: crossed
    CHECK(v(8, 8, 7) == lattice::edge_midpoint_value(v(8, 8, 6), v(8, 8, 8)));  // 22, 24
    // Edge shared with (1,2,2): y = 8, z = 8, x odd.
    CHECK(v(5, 8, 8) == was(5, 8, 8));  // 20, 22: crossed
    CHECK(v(7, 8, 8) == lattice::edge_midpoint_value(v(6, 8, 8), v(8, 8, 8)));  // 22, 24
    // Points off any level-2 boundary and level-2 lattice points keep their values.
    CHECK(v(9, 5, 5) == was(9, 5, 5));
    CHECK(v(8, 6, 6) == was(8, 6, 6));
    const FinePointMap once = field;
    apply_transition_continuity(cells, frame, field);
    CHECK(std::ranges::equal(field.values(), once.values()));
}

TEST_CASE("transition continuity matches a brute-force reference on random mixed blocks", "[mesh]") {
    const LatticeFrame frame{glm::vec3(0.0f), 1.0f, 4, {}};
    const int cs = frame.coarse_steps;
    for (int seed = 0; seed < 200; ++seed) {
        std::mt19937 rng(std::uint32_t(seed) + 77u);
        std::vector<CoarseCell> cells = test::block_cells({3, 3, 2}, {1, 2, 1}, 3);
        for (CoarseCell& c : cells) c.level = rng() % 2 ? 2 : 3;
        FinePointMap field = test::make_field(cells, frame, [&](glm::ivec3) {
            return std::uniform_real_distribution<float>(-1.0f, 1.0f)(rng);
        });
        const FinePointMap before = field;
        apply_transition_continuity(cells, frame, field);
        int mismatches = 0;
        for (std::size_t s = 0; s < field.capacity(); ++s) {
            const std::uint64_t key = field.key_at(s);
            if (key == lattice::kEmptyKey) continue;
            const glm::ivec3 p = lattice::unpack(key);
            bool on_level2_boundary = false;
            for (const CoarseCell& c : cells) {
                const glm::ivec3 lo = c.coord * cs, hi = lo + cs;
                if (c.level == 2 && glm::all(glm::greaterThanEqual(p, lo)) && glm::all(glm::lessThanEqual(p, hi)) &&
                    test::on_box_boundary(p, lo, hi))
                    on_level2_boundary = true;
            }
            auto v0 = [&](glm::ivec3 q) { return *before.find(q); };
            float expect = *before.find(p);
            const int odd = (p.x & 1) + (p.y & 1) + (p.z & 1);
            if (on_level2_boundary && odd == 1) {  // a level-2 edge midpoint: interpolated if uncrossed
                const glm::ivec3 e(p.x & 1, p.y & 1, p.z & 1);
                const float a = v0(p - e), b = v0(p + e);
                if (mc::inside(a) == mc::inside(b)) expect = lattice::edge_midpoint_value(a, b);
            }
            mismatches += field.values()[s] != expect;
        }
        INFO("seed " << seed);
        CHECK(mismatches == 0);
    }
}

TEST_CASE("cell index: levels and list positions by coordinate, absent and negative coordinates") {
    const std::vector<CoarseCell> cells = {{{3, 1, 4}, 2}, {{0, 0, 0}, 3}, {{1023, 7, 2}, 3}, {{3, 1, 5}, 2}};
    const CellIndex index(cells);
    for (std::size_t i = 0; i < cells.size(); ++i) {
        CHECK(index.level(cells[i].coord) == cells[i].level);
        CHECK(index.position(cells[i].coord) == std::int64_t(i));
    }
    for (const glm::ivec3 absent : {glm::ivec3(3, 1, 3), glm::ivec3(-1, 0, 0), glm::ivec3(0, -5, 2), glm::ivec3(1, 0, 0)}) {
        CHECK(index.level(absent) == 0);
        CHECK(index.position(absent) == -1);
    }
    const CellIndex empty(std::vector<CoarseCell>{});
    CHECK(empty.position({0, 0, 0}) == -1);
}
