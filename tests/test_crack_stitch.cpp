// Adaptive property test of docs/design.md §7: random fields on blocks mixing level-2 and level-3 cells
// give closed, oriented meshes whose patch triangles lie on transition faces ([mesh]).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>

#include <tbb/task_arena.h>

#include "crack_stitch.hpp"
#include "mesh_test_support.hpp"
#include "reference/edge_refinement.hpp"
#include "surface_mesher.hpp"
#include "test_support.hpp"
#include "transition_continuity.hpp"

using namespace trilevel;

namespace {

int level_at(const std::vector<CoarseCell>& cells, glm::ivec3 c) {
    for (const CoarseCell& cell : cells)
        if (cell.coord == c) return cell.level;
    return 0;
}

// Does the patch triangle lie in one level-2 fine face (2x2 steps) of a level-2/level-3 face?
bool on_transition_face(const std::vector<CoarseCell>& cells, int cs, const glm::vec3 (&v)[3]) {
    for (int a = 0; a < 3; ++a) {
        const float plane = v[0][a];
        if (v[1][a] != plane || v[2][a] != plane || plane != std::floor(plane) || int(plane) % cs) continue;
        const int b = (a + 1) % 3, c = (a + 2) % 3;
        const glm::vec3 lo = glm::min(v[0], glm::min(v[1], v[2])), hi = glm::max(v[0], glm::max(v[1], v[2]));
        for (int db = -2; db <= 0; db += 2)
            for (int dc = -2; dc <= 0; dc += 2) {
                const int fb = 2 * int(std::floor(lo[b] / 2)) + db, fc = 2 * int(std::floor(lo[c] / 2)) + dc;
                if (lo[b] < fb || hi[b] > fb + 2 || lo[c] < fc || hi[c] > fc + 2) continue;
                glm::ivec3 c0;
                c0[a] = int(plane) / cs - 1;
                c0[b] = int(std::floor(fb / double(cs)));
                c0[c] = int(std::floor(fc / double(cs)));
                glm::ivec3 c1 = c0;
                c1[a] += 1;
                const int l0 = level_at(cells, c0), l1 = level_at(cells, c1);
                if ((l0 == 2 && l1 == 3) || (l0 == 3 && l1 == 2)) return true;
            }
    }
    return false;
}

// One random field of one of several kinds; many exact zeros and ambiguous faces.
float random_value(std::mt19937& rng, int kind, glm::ivec3 p) {
    switch (kind) {
        case 0: return float(int(rng() % 5) - 2);              // {-2..2}
        case 1: return float(int(rng() % 3) - 1);              // {-1, 0, 1}
        case 2: return (rng() % 2) ? 1.0f : -1.0f;             // no zeros, maximal ambiguity
        case 3: return std::uniform_real_distribution<float>(-1.0f, 1.0f)(rng);
        case 4: {                                              // signed zeros and denormals
            constexpr float tiny = std::numeric_limits<float>::denorm_min();
            constexpr float set[6] = {-1.0f, -0.0f, 0.0f, tiny, -tiny, 1.0f};
            return set[rng() % 6];
        }
        default: {                                             // smooth plus noise
            const float s = std::sin(0.9f * p.x) + std::cos(0.7f * p.y) + std::sin(1.3f * p.z + 0.5f);
            return s + std::uniform_real_distribution<float>(-0.3f, 0.3f)(rng);
        }
    }
}

struct AdaptiveCase {
    LatticeFrame frame{glm::vec3(0.0f), 1.0f, 4, {}};
    std::vector<CoarseCell> cells;
    FinePointMap field;
};

AdaptiveCase random_adaptive_case(std::uint32_t seed, int coarse_steps = 4) {
    std::mt19937 rng(seed);
    AdaptiveCase c;
    c.frame.coarse_steps = coarse_steps;
    const int cs = c.frame.coarse_steps;
    const glm::ivec3 dims(2 + int(rng() % 2), 2 + int(rng() % 2), 2 + int(rng() % 2));
    const glm::ivec3 off(int(rng() % 2), int(rng() % 2), int(rng() % 2));
    const double p2 = 0.2 + 0.6 * (rng() % 4) / 3.0;
    c.cells = test::block_cells(dims, off, 3);
    for (CoarseCell& cell : c.cells) cell.level = std::uniform_real_distribution<double>(0, 1)(rng) < p2 ? 2 : 3;
    const int kind = int(rng() % 6);
    const glm::ivec3 lo = off * cs, hi = (off + dims) * cs;
    c.field = test::make_field(c.cells, c.frame, [&](glm::ivec3 p) {
        return test::on_box_boundary(p, lo, hi) ? 1.0f : random_value(rng, kind, p);
    });
    apply_transition_continuity(c.cells, c.frame, c.field);
    if (rng() % 2) {  // level-2 edge refinement: any value at midpoints of crossed level-2 edges
        for (std::uint64_t key : edge_refinement_points(c.cells, c.frame, c.field))
            c.field.insert(key, random_value(rng, int(rng() % 6), lattice::unpack(key)));
        apply_transition_continuity(c.cells, c.frame, c.field);
    }
    return c;
}

}  // namespace

TEST_CASE("adaptive property test: 10000 random fields give closed oriented meshes", "[mesh]") {
    // TRILEVEL_PROPERTY_FIELDS=N runs a longer soak (default 10,000). Each field is meshed with
    // patches alone and with the collapse; a collapse removes one vertex and two triangles.
    const char* env = std::getenv("TRILEVEL_PROPERTY_FIELDS");
    const int kFields = env ? std::max(1, std::atoi(env)) : 10000;
    int failures = 0;
    std::size_t patches = 0, triangles = 0, transition_meshes = 0, collapsed = 0, collapsed_meshes = 0, left = 0, flat = 0, non_simple = 0;
    std::size_t sampled = 0, crossing_patches = 0, crossing_collapsed = 0;
    for (int seed = 0; seed < kFields; ++seed) {
        AdaptiveCase c = random_adaptive_case(std::uint32_t(seed) * 2654435761u + 17u);
        std::size_t merged = 0;
        const Mesh m = triangulate_cells(c.cells, c.frame, c.field, CrackClosing::Patches);
        const Mesh k = triangulate_cells(c.cells, c.frame, c.field, CrackClosing::Collapse, &merged);
        for (const Mesh* mesh : {&m, &k}) {
            const auto r = mesh_topology_report(*mesh);
            if (!r.closed_and_oriented() && ++failures <= 5)
                FAIL_CHECK("seed " << seed << (mesh == &k ? " (collapse)" : " (patches)") << ": boundary " << r.boundary_edges
                                   << " conflicts " << r.orientation_conflicts << " non-manifold " << r.non_manifold_edges
                                   << " degenerate " << r.degenerate_triangles);
        }
        const test::PatchFolds folds = test::patch_folds(m);
        flat += folds.flat;
        non_simple += folds.non_simple;
        if (folds.flipped && ++failures <= 5)
            FAIL_CHECK("seed " << seed << ": " << folds.flipped << " patch triangles folded against their crack polygon");
        if (seed % 10 == 0) {  // sampled: pairs of triangles without a shared vertex that cross
            // Random fields make crack polygons that are not simple (their level-2 and level-3
            // outlines cross), which no triangulation lays flat: such patches may cross, counted
            // and reported. The collapse must add no crossing: where the patches cross nowhere,
            // neither does the collapsed mesh.
            const std::size_t xm = test::self_intersections(m), xk = test::self_intersections(k);
            crossing_patches += xm != 0;
            crossing_collapsed += xk != 0;
            if (xm == 0 && xk != 0 && ++failures <= 5)
                FAIL_CHECK("seed " << seed << ": the collapse made " << xk << " pairs of triangles cross");
            ++sampled;
        }
        if (k.vertex_count() + merged != m.vertex_count() || k.triangle_count() + 2 * merged != m.triangle_count())
            if (++failures <= 5) FAIL_CHECK("seed " << seed << ": " << merged << " collapses do not account for the counts");
        std::size_t here = 0;
        for (const Mesh* mesh : {&m, &k})
            for (std::size_t t = 0; t < mesh->triangle_count(); ++t) {
                if (mesh->triangle_kind[t] != TriangleKind::Patch) continue;
                here += mesh == &m;
                left += mesh == &k;
                glm::vec3 v[3];
                for (int j = 0; j < 3; ++j) {
                    const std::uint32_t i = mesh->triangles[3 * t + j];
                    v[j] = {mesh->positions[3 * i], mesh->positions[3 * i + 1], mesh->positions[3 * i + 2]};
                }
                if (!on_transition_face(c.cells, c.frame.coarse_steps, v) && ++failures <= 5)
                    FAIL_CHECK("seed " << seed << ": patch triangle " << t << " off every transition face");
            }
        patches += here;
        triangles += m.triangle_count();
        transition_meshes += here > 0;
        collapsed += merged;
        collapsed_meshes += merged > 0;
    }
    CHECK(failures == 0);
    CHECK(transition_meshes > std::size_t(kFields) / 4);  // the patches are exercised, not just allowed
    CHECK(collapsed_meshes > transition_meshes / 2);      // and so are the collapses
    CHECK(left < patches);
    CHECK(crossing_collapsed <= crossing_patches);
    WARN(kFields << " adaptive fields: " << triangles << " triangles, " << patches << " patches in " << transition_meshes
                 << " meshes; the collapse merged " << collapsed << " vertices in " << collapsed_meshes << " meshes, "
                 << left << " patches left, " << flat << " patch triangles of zero area, " << non_simple << " crack polygons not simple; of "
                 << sampled << " sampled fields " << crossing_patches << " have crossing triangles with patches, "
                 << crossing_collapsed << " after the collapse");
}

TEST_CASE("adaptive property test with coarse cells of 2 and 6 steps", "[mesh]") {
    int failures = 0;
    for (int cs : {2, 6})
        for (int seed = 0; seed < 1000; ++seed) {
            AdaptiveCase c = random_adaptive_case(std::uint32_t(seed) * 40503u + std::uint32_t(cs), cs);
            for (CrackClosing closing : {CrackClosing::Patches, CrackClosing::Collapse}) {
                const Mesh m = triangulate_cells(c.cells, c.frame, c.field, closing);
                const auto r = mesh_topology_report(m);
                if (!r.closed_and_oriented() && ++failures <= 5) FAIL_CHECK("coarse_steps " << cs << " seed " << seed);
                if (closing == CrackClosing::Patches && test::patch_folds(m).flipped && ++failures <= 5)
                    FAIL_CHECK("coarse_steps " << cs << " seed " << seed << ": folded patch triangles");
            }
        }
    CHECK(failures == 0);
}

TEST_CASE("crack stitching: one level-2 cell beside one level-3 cell", "[mesh]") {
    // A saddle-like field on the shared face: ambiguous level-2 face, inner crossings on level 3.
    const LatticeFrame frame{glm::vec3(0.0f), 1.0f, 4, {}};
    for (int order = 0; order < 2; ++order) {
        std::vector<CoarseCell> cells = {{{1, 1, 1}, std::uint8_t(order ? 3 : 2)}, {{2, 1, 1}, std::uint8_t(order ? 2 : 3)}};
        const glm::ivec3 lo(4, 4, 4), hi(12, 8, 8);
        FinePointMap field = test::make_field(cells, frame, [&](glm::ivec3 p) {
            if (test::on_box_boundary(p, lo, hi)) return 1.0f;
            return float((p.y - 6) * (p.z - 6)) - 0.5f + 0.1f * float(p.x - 8);
        });
        apply_transition_continuity(cells, frame, field);
        const Mesh m = triangulate_cells(cells, frame, field);
        INFO("level-3 cell on the " << (order ? "left" : "right"));
        CHECK(is_closed_and_oriented(m));
        CHECK(test::signed_volume(m) > 0.0);
        CHECK(std::count(m.vertex_level.begin(), m.vertex_level.end(), 2) > 0);
        CHECK(std::count(m.vertex_level.begin(), m.vertex_level.end(), 3) > 0);
    }
}

TEST_CASE("adaptive sphere with random levels: closed, outward, same output on 1 and 2 threads", "[mesh]") {
    const LatticeFrame frame{glm::vec3(-1.0f, 0.25f, 2.0f), 0.125f, 4, {}};
    const glm::dvec3 centre(50.3, 49.6, 50.2);
    const double radius = 30.0;
    std::vector<CoarseCell> cells;
    std::mt19937 rng(99);
    for (int z = 0; z < 25; ++z)
        for (int y = 0; y < 25; ++y)
            for (int x = 0; x < 25; ++x) {
                const glm::dvec3 lo = glm::dvec3(x, y, z) * 4.0, hi = lo + 4.0;
                const glm::dvec3 nr = glm::clamp(centre, lo, hi);
                glm::dvec3 far;
                for (int k = 0; k < 3; ++k) far[k] = std::abs(centre[k] - lo[k]) > std::abs(centre[k] - hi[k]) ? lo[k] : hi[k];
                if (glm::length(nr - centre) <= radius && glm::length(far - centre) >= radius)
                    cells.push_back({{x, y, z}, std::uint8_t(rng() % 2 ? 3 : 2)});
            }
    FinePointMap field = test::make_field(cells, frame, [&](glm::ivec3 p) {
        return float(glm::length(glm::dvec3(p) - centre) - radius);
    });
    apply_transition_continuity(cells, frame, field);
    std::size_t merged = 0;
    auto run = [&](int threads, CrackClosing closing) {
        tbb::task_arena arena(threads);
        Mesh m;
        arena.execute([&] { m = triangulate_cells(cells, frame, field, closing, &merged); });
        return m;
    };
    const Mesh a = run(1, CrackClosing::Patches), b = run(2, CrackClosing::Patches);
    CHECK(is_closed_and_oriented(a));
    CHECK(a.positions == b.positions);
    CHECK(a.triangles == b.triangles);
    CHECK(a.vertex_level == b.vertex_level);
    CHECK(a.triangle_kind == b.triangle_kind);
    const double r = radius * frame.step, ball = 4.0 / 3.0 * M_PI * r * r * r;
    CHECK(std::abs(test::signed_volume(a) - ball) < 0.02 * ball);
    const auto patches = std::count(a.triangle_kind.begin(), a.triangle_kind.end(), TriangleKind::Patch);
    CHECK(patches > 0);
    CHECK(double(patches) < 0.15 * double(a.triangle_count()));  // half the faces are transitions here

    // The collapse: same output on 1 and 2 threads, closed, the same ball, most patches gone.
    const Mesh c = run(1, CrackClosing::Collapse), d = run(2, CrackClosing::Collapse);
    CHECK(c.positions == d.positions);
    CHECK(c.triangles == d.triangles);
    CHECK(c.triangle_kind == d.triangle_kind);
    CHECK(is_closed_and_oriented(c));
    CHECK(c.triangle_count() + 2 * merged == a.triangle_count());
    CHECK(std::abs(test::signed_volume(c) - ball) < 0.02 * ball);
    const auto left = std::count(c.triangle_kind.begin(), c.triangle_kind.end(), TriangleKind::Patch);
    CHECK(merged > std::size_t(patches) / 2);
    CHECK(left < patches / 10);
    CHECK(test::patch_folds(a).flipped == 0);
    CHECK(test::self_intersections(a) == 0);
    CHECK(test::self_intersections(c) == 0);
}


TEST_CASE("triangulation calls field_done once and reads the field no more after it", "[mesh]") {
    // The reconstructor frees the fine-point table in field_done, before the crack collapse builds
    // its crossing grid: here the callback overwrites every value instead, and the meshes must keep
    // their bits, with the collapse and with patches.
    int failures = 0;
    for (int seed = 0; seed < 200; ++seed) {
        AdaptiveCase c = random_adaptive_case(std::uint32_t(seed) * 7919u + 5u);
        for (CrackClosing closing : {CrackClosing::Patches, CrackClosing::Collapse}) {
            std::size_t merged = 0, merged_poisoned = 0;
            const Mesh plain = triangulate_cells(c.cells, c.frame, c.field, closing, &merged);
            FinePointMap poisoned = c.field;
            int calls = 0;
            const Mesh m = triangulate_cells(c.cells, c.frame, poisoned, closing, &merged_poisoned, {}, nullptr, [&] {
                ++calls;
                for (float& v : poisoned.values()) v = std::numeric_limits<float>::quiet_NaN();
            });
            const bool same = calls == 1 && m.positions == plain.positions && m.triangles == plain.triangles &&
                              m.vertex_level == plain.vertex_level && m.triangle_kind == plain.triangle_kind &&
                              merged == merged_poisoned;
            if (!same && ++failures <= 5)
                FAIL_CHECK("seed " << seed << (closing == CrackClosing::Collapse ? " (collapse)" : " (patches)") << ": "
                                   << calls << " calls, " << m.triangle_count() << " against " << plain.triangle_count()
                                   << " triangles");
        }
    }
    CHECK(failures == 0);
}
