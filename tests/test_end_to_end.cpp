// End to end: particles in, closed and consistently oriented mesh out, bit-identical across runs
// and work-group sizes; every ../shared/data frame in every mode.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <random>

#include <glm/glm.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "mesh_test_support.hpp"
#include "mesh_topology.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"
#include "trilevel/trilevel.hpp"

using namespace trilevel;
using trilevel::test::require_closed;
using trilevel::test::same_mesh;
using trilevel::test::signed_volume;

namespace {

/// One Reconstructor for the whole suite (kernels compiled once); every use is a single frame, so
/// no level history carries over from an earlier, unrelated reconstruction.
Reconstructor& shared_reconstructor() {
    static Reconstructor rec;
    rec.reset_history();
    return rec;
}

Params params(float r, Mode mode, float cell = 1.0f) {
    Params p;
    p.particle_radius = r;
    p.mode = mode;
    p.cell = cell;
    return p;
}

/// Distance from p to triangle abc (closest point by the triangle's Voronoi regions).
double point_triangle_distance(glm::dvec3 p, glm::dvec3 a, glm::dvec3 b, glm::dvec3 c) {
    const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return glm::length(p - a);
    const glm::dvec3 bp = p - b;
    const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return glm::length(p - b);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return glm::length(p - (a + ab * (d1 / (d1 - d3))));
    const glm::dvec3 cp = p - c;
    const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return glm::length(p - c);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return glm::length(p - (a + ac * (d2 / (d2 - d6))));
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) return glm::length(p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))));
    const double den = 1.0 / (va + vb + vc);
    return glm::length(p - (a + ab * (vb * den) + ac * (vc * den)));
}

/// The 99th percentile over the vertices of `from` of their distance to the surface `to` (brute
/// force: small meshes only).
double vertex_distance_p99(const Mesh& from, const Mesh& to) {
    auto vertex = [](const Mesh& m, std::size_t v) {
        return glm::dvec3(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]);
    };
    std::vector<double> d(from.vertex_count());
    tbb::parallel_for(std::size_t(0), d.size(), [&](std::size_t v) {
        double best = 1e300;
        for (std::size_t t = 0; t < to.triangle_count(); ++t)
            best = std::min(best, point_triangle_distance(vertex(from, v), vertex(to, to.triangles[3 * t]),
                                                          vertex(to, to.triangles[3 * t + 1]), vertex(to, to.triangles[3 * t + 2])));
        d[v] = best;
    });
    std::sort(d.begin(), d.end());
    return d[std::size_t(0.99 * double(d.size() - 1))];
}

}  // namespace

TEST_CASE("a generated sphere gives a closed mesh of the ball's volume in every mode", "[e2e]") {
    const float r = 0.025f;
    ParticleSet s = generate_scene("sphere", r, 1);
    // Volume of the fluid = particle count x volume per particle (2r)^3.
    const double fluid = double(s.size()) * std::pow(2.0 * r, 3);
    for (auto [mode, cell] : {std::pair{Mode::Uniform, 2.0f}, {Mode::Uniform, 1.0f}, {Mode::Adaptive, 1.0f}}) {
        Stats st;
        Mesh m = shared_reconstructor().reconstruct(s.positions.data(), s.size(), params(r, mode, cell), &st);
        require_closed(m, "cell " + std::to_string(cell));
        CHECK(st.closed);
        CHECK(st.particles == s.size());
        CHECK(st.triangles == m.triangle_count());
        CHECK(signed_volume(m) == Approx(fluid).epsilon(0.10));
    }
}

TEST_CASE("one isolated particle gives a closed blob around it", "[e2e]") {
    const float xyz[3] = {1.0f, -2.0f, 3.0f};
    const float r = 0.1f;
    Mesh m = shared_reconstructor().reconstruct(xyz, 1, params(r, Mode::Adaptive));
    require_closed(m, "single particle");
    // The blob is the sphere phi = |x - c| - r (Solenthaler with one neighbour).
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
        glm::vec3 p(m.positions[3 * v] - xyz[0], m.positions[3 * v + 1] - xyz[1], m.positions[3 * v + 2] - xyz[2]);
        REQUIRE(glm::length(p) == Approx(r).epsilon(0.02));
    }
}

TEST_CASE("output is bit-identical across runs, reconstructors and work-group sizes", "[e2e][determinism]") {
    const float r = 0.025f;
    ParticleSet s = generate_scene("pool-and-drop", r, 3);
    for (Mode mode : {Mode::Adaptive, Mode::Uniform}) {
        Mesh a = shared_reconstructor().reconstruct(s.positions.data(), s.size(), params(r, mode));
        Mesh b = shared_reconstructor().reconstruct(s.positions.data(), s.size(), params(r, mode));
        REQUIRE(same_mesh(a, b));
        for (const char* wg : {"0", "1", "16", "64"}) {  // 0: the driver chooses; the default is 256
            ::setenv("TRILEVEL_WORK_GROUP", wg, 1);
            Reconstructor other;
            Mesh c = other.reconstruct(s.positions.data(), s.size(), params(r, mode));
            ::unsetenv("TRILEVEL_WORK_GROUP");
            INFO("work-group size " << wg);
            REQUIRE(same_mesh(a, c));
        }
        ::setenv("TRILEVEL_SERIAL_GATHER", "0", 1);  // candidates copied by every work-item, as on GPUs
        Reconstructor cooperative;
        ::unsetenv("TRILEVEL_SERIAL_GATHER");
        REQUIRE(same_mesh(a, cooperative.reconstruct(s.positions.data(), s.size(), params(r, mode))));
        for (const char* lanes : {"8", "16"}) {  // vector lanes: 16 on AVX-512 CPUs (and colour-field bins paired), 8 on GPUs
            ::setenv("TRILEVEL_VECTOR_WIDTH", lanes, 1);
            Reconstructor other;
            ::unsetenv("TRILEVEL_VECTOR_WIDTH");
            INFO("vector width " << lanes);
            REQUIRE(same_mesh(a, other.reconstruct(s.positions.data(), s.size(), params(r, mode))));
        }
    }
}

TEST_CASE("output is bit-identical on 1 to 16 host threads", "[e2e][determinism]") {
    // The host stages split work by thread count: the vertex numbering beside the meshing (few
    // threads) or after it on all threads (many), the crack collapse and the sliver cleanup in
    // tiles, the smoothing's sweeps. Arenas of these sizes take the paths of that many threads
    // (their max_concurrency), also on a machine with fewer cores, where fewer threads run them.
    const float r = 0.025f;
    std::vector<std::pair<std::string, ParticleSet>> frames = {{"falling-drop", generate_scene("falling-drop", r, 5)},
                                                               {"pool-and-drop", generate_scene("pool-and-drop", r, 5)}};
    if (const auto dir = trilevel::test::shared_data_dir(); !dir.empty())  // the real frame has the most crack runs
        frames.emplace_back("db23", read_particles((dir / "dam_break_frame_23_24389_particles.bgeo").string()));
    for (const auto& [scene, s] : frames) {
        for (bool smooth : {false, true}) {
            Params p = params(r, Mode::Adaptive);
            p.smooth = smooth;
            Mesh one;
            Stats st;
            tbb::task_arena(1).execute([&] { one = shared_reconstructor().reconstruct(s.positions.data(), s.size(), p, &st); });
            INFO(scene << (smooth ? ", smoothed" : ""));
            REQUIRE(st.crack_vertices_collapsed > 0);  // the collapse had work to split
            require_closed(one, scene);
            for (int threads : {2, 3, 16}) {
                Mesh m;
                tbb::task_arena(threads).execute([&] { m = shared_reconstructor().reconstruct(s.positions.data(), s.size(), p); });
                INFO(threads << " threads");
                REQUIRE(same_mesh(one, m));
            }
        }
    }
}

TEST_CASE("32-bit fine-point keys give the mesh of 64-bit ones", "[e2e][determinism]") {
    const float r = 0.025f;
    const ParticleSet s = generate_scene("pool-and-drop", r, 3);
    for (Mode mode : {Mode::Adaptive, Mode::Uniform}) {
        Stats narrow_stats;
        const Mesh narrow = shared_reconstructor().reconstruct(s.positions.data(), s.size(), params(r, mode), &narrow_stats);
        ::setenv("TRILEVEL_FINE_KEYS", "64", 1);  // test hook (reconstructor.cpp, make_grid)
        Stats wide_stats;
        const Mesh wide = shared_reconstructor().reconstruct(s.positions.data(), s.size(), params(r, mode), &wide_stats);
        ::unsetenv("TRILEVEL_FINE_KEYS");
        CHECK(narrow_stats.fine_points == wide_stats.fine_points);
        REQUIRE(same_mesh(narrow, wide));
    }
}

TEST_CASE("positions handed over give the same mesh as positions lent, also with normals", "[e2e]") {
    const float r = 0.025f;
    ParticleSet s = generate_scene("pool-and-drop", r, 3);
    for (trilevel::NormalMode normals : {trilevel::NormalMode::None, trilevel::NormalMode::Gradient}) {
        trilevel::Params p = params(r, Mode::Adaptive);
        p.normals = normals;  // with normals the positions are read again after the mesh is made
        const Mesh lent = shared_reconstructor().reconstruct(s.positions.data(), s.size(), p);
        std::vector<float> copy = s.positions;
        const Mesh handed = shared_reconstructor().reconstruct(std::move(copy), p);
        REQUIRE(same_mesh(lent, handed));
        REQUIRE(lent.normals == handed.normals);
    }
    std::vector<float> ragged(7, 1.0f);
    REQUIRE_THROWS_WITH(shared_reconstructor().reconstruct(std::move(ragged), params(r, Mode::Adaptive)),
                        Catch::Contains("7 floats are not x, y, z triplets"));
}

TEST_CASE("every generated scene reconstructs closed and oriented in every mode", "[e2e]") {
    const float r = 0.025f;
    for (const std::string& name : scene_names()) {
        ParticleSet s = generate_scene(name, r, 2);
        for (auto [mode, cell] : {std::pair{Mode::Uniform, 2.0f}, {Mode::Uniform, 1.0f}, {Mode::Adaptive, 1.0f}}) {
            Mesh m = shared_reconstructor().reconstruct(s.positions.data(), s.size(), params(r, mode, cell));
            require_closed(m, name + " cell " + std::to_string(cell) + (mode == Mode::Adaptive ? " adaptive" : ""));
        }
    }
}

TEST_CASE("every ../shared/data frame reconstructs closed and oriented at cells 2 and 1 and adaptive", "[e2e][shared]") {
    TRILEVEL_REQUIRE_SHARED_DATA(dir);
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        const std::string ext = entry.path().extension().string();
        if (ext != ".vtk" && ext != ".vtu" && ext != ".bgeo") continue;
        // Radii (shared/tools/README.md): 0.025 for the SPlisHSPlasH frames, 0.5 for free_particles;
        // cube_8 (spacing 0.5) and the fluid_*_250 VTU files (spacing ~0.14) use their own scales.
        float r = 0.025f;
        if (name.rfind("free_particles", 0) == 0 || name.rfind("cube_8_", 0) == 0) r = 0.25f;
        if (name.rfind("free_particles", 0) == 0) r = 0.5f;
        if (name.rfind("fluid_", 0) == 0) r = 0.07f;
        ParticleSet s = read_particles(entry.path().string());
        for (auto [mode, cell] : {std::pair{Mode::Uniform, 2.0f}, {Mode::Uniform, 1.0f}, {Mode::Adaptive, 1.0f}}) {
            Stats st;
            Mesh m = shared_reconstructor().reconstruct(s.positions.data(), s.size(), params(r, mode, cell), &st);
            require_closed(m, name + " cell " + std::to_string(cell) + (mode == Mode::Adaptive ? " adaptive" : ""));
            if (mode == Mode::Adaptive) {
                CHECK(st.triangles_level2 + st.triangles_level3 + st.triangles_patch == st.triangles);
                // Sampled (every 3rd triangle against its neighbourhood): the crack collapse and the
                // patches must not make non-adjacent triangles cross.
                INFO(name);
                CHECK(test::self_intersections(m, 3) == 0);
            }
        }
    }
}

TEST_CASE("db23 at r 0.025: no two triangles cross after the crack collapse and the sliver cleanup", "[e2e][shared]") {
    // Every triangle against its neighbourhood (the frames above sample every third): both collapses
    // refuse a merge that moves a triangle through another one.
    TRILEVEL_REQUIRE_SHARED_DATA(dir);
    const ParticleSet s = read_particles((dir / "dam_break_frame_23_24389_particles.bgeo").string());
    for (bool sliver : {false, true}) {
        Params p = params(0.025f, Mode::Adaptive);
        p.sliver_cleanup = sliver;
        Stats st;
        const Mesh m = shared_reconstructor().reconstruct(s.positions.data(), s.size(), p, &st);
        INFO("sliver cleanup " << sliver);
        require_closed(m, "db23");
        CHECK(st.crack_vertices_collapsed > 0);
        CHECK((st.sliver_edges_collapsed > 0) == sliver);
        CHECK(test::self_intersections(m) == 0);
    }
}

TEST_CASE("bad input to the library is a clear error", "[e2e][errors]") {
    const float ok[6] = {0, 0, 0, 0.05f, 0, 0};
    const float nan[3] = {0, std::nanf(""), 0};
    auto& rec = shared_reconstructor();
    REQUIRE_THROWS_WITH(rec.reconstruct(ok, 0, params(0.025f, Mode::Adaptive)), Catch::Contains("empty"));
    REQUIRE_THROWS_WITH(rec.reconstruct(nan, 1, params(0.025f, Mode::Adaptive)), Catch::Contains("non-finite"));
    REQUIRE_THROWS_WITH(rec.reconstruct(ok, 2, params(0.0f, Mode::Adaptive)), Catch::Contains("particle radius"));
    REQUIRE_THROWS_WITH(rec.reconstruct(ok, 2, params(-1.0f, Mode::Adaptive)), Catch::Contains("particle radius"));
    REQUIRE_THROWS_WITH(rec.reconstruct(ok, 2, params(0.025f, Mode::Uniform, 3.0f)), Catch::Contains("cell size"));
    // A memory budget too small for the buffers: an error naming the budget, not an allocation.
    Params tight = params(0.025f, Mode::Adaptive);
    tight.memory_limit_bytes = 64 * 1024;
    ParticleSet sphere = generate_scene("sphere", 0.025f, 1);
    REQUIRE_THROWS_WITH(rec.reconstruct(sphere.positions.data(), sphere.size(), tight), Catch::Contains("budget"));
    // A particle at 1e6 world units: float32 coordinates there are 0.0625 apart, coarser than r/4.
    // (Wide but resolvable domains are split into lattices of their own: test_robustness.cpp.)
    const float far[6] = {0, 0, 0, 1e6f, 0, 0};
    REQUIRE_THROWS_WITH(rec.reconstruct(far, 2, params(0.025f, Mode::Adaptive)), Catch::Contains("cannot resolve"));
}

TEST_CASE("levels end to end: a 6r droplet is level 3, a resting pool level 2, isolated particles level 3", "[e2e][levels]") {
    const float r = 0.025f;
    auto& rec = shared_reconstructor();
    // A ball of radius 6r on the 2r lattice (docs/design.md §3.2: curvature ~0.5-1 there, a flat face < 0.01).
    std::vector<float> ball;
    for (int k = -3; k <= 3; ++k)
        for (int j = -3; j <= 3; ++j)
            for (int i = -3; i <= 3; ++i)
                if (i * i + j * j + k * k <= 9)
                    for (float c : {float(i), float(j), float(k)}) ball.push_back(2 * r * c + 0.3f * r);
    Params p = params(r, Mode::Adaptive);
    p.curvature_threshold = 0.5f;
    Stats st;
    Mesh m = rec.reconstruct(ball.data(), ball.size() / 3, p, &st);
    require_closed(m, "6r ball");
    CHECK(st.surface_cells_level2 == 0);
    CHECK(st.triangles_level2 == 0);
    CHECK(st.triangles_patch == 0);

    // The generated pool-and-drop: its flat pool is level 2 at the same threshold, while the drop,
    // the jet and the splash particles make level-3 cells, and crack patches close the seams; the
    // default closing then merges their inner crossings away, two triangles fewer per vertex.
    ParticleSet pd = generate_scene("pool-and-drop", r, 1);
    p.crack_closing = CrackClosing::Patches;
    Stats patched;
    m = rec.reconstruct(pd.positions.data(), pd.size(), p, &patched);
    require_closed(m, "pool-and-drop at threshold 0.5, patches");
    CHECK(patched.triangles_patch > 0);
    CHECK(patched.crack_vertices_collapsed == 0);
    p.crack_closing = CrackClosing::Collapse;
    m = rec.reconstruct(pd.positions.data(), pd.size(), p, &st);
    require_closed(m, "pool-and-drop at threshold 0.5");
    CHECK(st.surface_cells_level2 > 2 * st.surface_cells_level3);
    CHECK(st.surface_cells_level3 > 0);
    CHECK(st.splash_cells > 0);
    CHECK(st.crack_vertices_collapsed > 0);
    CHECK(st.triangles_patch < patched.triangles_patch);
    CHECK(st.vertices + st.crack_vertices_collapsed == patched.vertices);
    CHECK(st.triangles + 2 * st.crack_vertices_collapsed == patched.triangles);
    CHECK(st.triangles_level2 + st.triangles_level3 + st.triangles_patch == st.triangles);

    // Isolated particles are splash particles: level 3 at the default threshold.
    const float two[6] = {0, 0, 0, 40 * r, 0, 0};
    m = rec.reconstruct(two, 2, params(r, Mode::Adaptive), &st);
    require_closed(m, "two isolated particles");
    CHECK(st.splash_particles == 2);
    CHECK(st.surface_cells_level2 == 0);
    CHECK(st.surface_cells_level3 > 0);
}

TEST_CASE("a sheet one particle thick stays one piece in adaptive mode, as at uniform r", "[e2e][levels]") {
    // At y = r the level-2 lattice (steps of 2r from the origin) puts its samples r off the sheet's
    // middle on both sides, where the field is near zero: without the sheet rule
    // (constants::kSheetNeighbourFraction) such a sheet came out in pieces with a third of its
    // volume gone.
    const float r = 0.025f;
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> jitter(-0.1f * r, 0.1f * r);
    for (int axis : {1, 2}) {  // flat in y, then in z
        std::vector<float> sheet;
        for (int a = 0; a < 30; ++a)
            for (int b = 0; b < 30; ++b) {
                glm::vec3 p(2.0f * r * a + jitter(rng), r + jitter(rng), 2.0f * r * b + jitter(rng));
                if (axis == 2) std::swap(p.y, p.z);
                sheet.insert(sheet.end(), {p.x, p.y, p.z});
            }
        const std::string what = axis == 1 ? "sheet flat in y" : "sheet flat in z";
        Stats st;
        Mesh adaptive = shared_reconstructor().reconstruct(sheet.data(), sheet.size() / 3, params(r, Mode::Adaptive), &st);
        Mesh uniform = shared_reconstructor().reconstruct(sheet.data(), sheet.size() / 3, params(r, Mode::Uniform, 1.0f));
        require_closed(adaptive, what);
        INFO(what);
        CHECK(mesh_components(adaptive).count == 1);
        CHECK(mesh_components(uniform).count == 1);
        CHECK(signed_volume(adaptive) == Approx(signed_volume(uniform)).epsilon(0.02));
        CHECK(st.surface_cells_level3 > 4 * st.surface_cells_level2);  // level 2 at the rim only
    }
}

TEST_CASE("a pile of particles a hundredth of r across meshes as one closed blob in both modes", "[e2e][robustness]") {
    // A radius far too large for the particles (a unit mix-up) makes the frame such a pile. It
    // failed in adaptive mode ("clEnqueueWriteBuffer returned CL_INVALID_VALUE") and gave an empty
    // mesh at uniform r: its particles were neither surface nor splash (constants::kPileFraction).
    const float r = 0.025f;
    const std::vector<glm::vec3> pile = test::pile_points(160, glm::vec3(2.0f, 3.0f, 4.0f), 0.01f * r, 11);
    for (Mode mode : {Mode::Adaptive, Mode::Uniform}) {
        INFO((mode == Mode::Adaptive ? "adaptive" : "uniform r"));
        const Mesh m = shared_reconstructor().reconstruct(&pile[0].x, pile.size(), params(r, mode, 1.0f));
        require_closed(m, "pile");
        REQUIRE(m.triangle_count() > 0);
        CHECK(mesh_components(m).count == 1);
        for (std::size_t v = 0; v < m.vertex_count(); ++v)  // around the pile, within the kernel's reach
            CHECK(glm::distance(glm::vec3(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]),
                                glm::vec3(2.0f, 3.0f, 4.0f)) < 4 * r);
    }
}

TEST_CASE("a block made on a lattice keeps its edges whichever parity of r its particle layers take", "[e2e][levels]") {
    // A fluid made on a lattice of spacing 2r (a simulator's first frame, a generated scene) has
    // its faces r beyond its outer layers. On the level-2 planes (layers on one parity of r) the 2r
    // lattice rounded each edge by up to 0.6 r; the lattice phase (make_grid) puts the layers on
    // the planes instead, so the faces lie midway between them, for either parity.
    const float r = 0.025f;
    for (int parity : {0, 1}) {
        const auto block = test::lattice_points(glm::ivec3(16, 8, 8), glm::vec3(float(parity) * r), 2 * r, 0.1f * r, 5);
        INFO("particle layers at " << (parity ? "odd" : "even") << " multiples of r");
        const Mesh adaptive = shared_reconstructor().reconstruct(&block[0].x, block.size(), params(r, Mode::Adaptive));
        const Mesh uniform = shared_reconstructor().reconstruct(&block[0].x, block.size(), params(r, Mode::Uniform, 1.0f));
        require_closed(adaptive, "block");
        const double there = vertex_distance_p99(adaptive, uniform) / r, back = vertex_distance_p99(uniform, adaptive) / r;
        INFO("p99 vertex distance, adaptive to uniform r " << there << " r, back " << back << " r");
        CHECK(there < 0.3);  // measured 0.10 / 0.14 r; 0.5-0.6 r before the phase on the odd layers
        CHECK(back < 0.3);
    }
}

TEST_CASE("the lattice phase of a sequence's first frame is kept while the level history lasts", "[e2e][levels]") {
    // The level history compares cells of one lattice, so a frame whose own phase would differ is
    // meshed on the phase of the frames before it; after reset_history() it takes its own again.
    const float r = 0.025f;
    // Layers at odd multiples of r, then the same block moved by r in x.
    const auto odd = test::lattice_points(glm::ivec3(10, 6, 6), glm::vec3(r), 2 * r, 0.1f * r, 9);
    auto even = odd;
    for (glm::vec3& x : even) x.x += r;
    Reconstructor& rec = shared_reconstructor();
    const Params p = params(r, Mode::Adaptive);  // no hysteresis: the history changes no level, only the phase is kept
    const Mesh alone = rec.reconstruct(&even[0].x, even.size(), p);
    rec.reset_history();
    rec.reconstruct(&odd[0].x, odd.size(), p);
    const Mesh after_odd = rec.reconstruct(&even[0].x, even.size(), p);
    CHECK_FALSE(same_mesh(alone, after_odd));
    require_closed(after_odd, "the moved block on the first frame's phase");
    rec.reset_history();
    CHECK(same_mesh(rec.reconstruct(&even[0].x, even.size(), p), alone));
}

TEST_CASE("work-groups whose candidates do not fit local memory fall back to global loops", "[e2e][fallback]") {
    // With room for 16 candidates every bin and cell overflows: colour field, curvature and scalar
    // field all take their global-memory paths (small-local-memory GPUs hit them on dense data).
    const float r = 0.025f;
    ParticleSet s = generate_scene("pool-and-drop", r, 1);
    Stats normal, fallback;
    Mesh a = shared_reconstructor().reconstruct(s.positions.data(), s.size(), params(r, Mode::Adaptive), &normal);
    ::setenv("TRILEVEL_MAX_CANDIDATES", "16", 1);
    Reconstructor small;
    ::unsetenv("TRILEVEL_MAX_CANDIDATES");
    Mesh b = small.reconstruct(s.positions.data(), s.size(), params(r, Mode::Adaptive), &fallback);
    Mesh c = small.reconstruct(s.positions.data(), s.size(), params(r, Mode::Adaptive));
    require_closed(b, "fallback paths");
    REQUIRE(same_mesh(b, c));  // deterministic on the fallback paths too
    CHECK(fallback.surface_particles == normal.surface_particles);
    CHECK(fallback.surface_cells == normal.surface_cells);
    CHECK(fallback.fine_points == normal.fine_points);
    CHECK(double(fallback.triangles) == Approx(double(normal.triangles)).epsilon(0.01));
}

TEST_CASE("a frame translated by 1e5 r gives the same mesh, translated, to the float resolution there", "[e2e][precision]") {
    // r = 1/32 and particle coordinates on a 2^-12 grid: the particles, the lattice (snapped to
    // coarse cells of 4r = 1/8) and so the field are the same bit for bit 1e5 r = 3125 away; only
    // turning lattice coordinates into output positions sees the translation. Each vertex must then
    // be its untranslated position plus the translation, rounded once to the float spacing there
    // (2^-12 = 0.0078 r), not lose more to intermediate float steps; but for the few that round
    // onto an end of their edge, which move one float step inside it (crossing_position in
    // host/surface_mesher.cpp: no two vertices on one point), within 1.5 spacings.
    const float r = 1.0f / 32.0f;
    ParticleSet s = generate_scene("pool-and-drop", r, 3);
    for (float& c : s.positions) c = std::ldexp(std::round(std::ldexp(c, 12)), -12);
    const float T = 1e5f * r;
    const double ulp = std::ldexp(1.0, -12);  // float spacing in [2048, 4096)
    const Mesh m0 = shared_reconstructor().reconstruct(s.positions.data(), s.size(), params(r, Mode::Adaptive));
    require_closed(m0, "pool-and-drop");
    for (int axis = 0; axis < 3; ++axis) {
        INFO("translated along axis " << axis);
        std::vector<float> moved = s.positions;
        for (std::size_t i = axis; i < moved.size(); i += 3) moved[i] += T;  // exact: on the 2^-12 grid
        const Mesh m1 = shared_reconstructor().reconstruct(moved.data(), s.size(), params(r, Mode::Adaptive));
        REQUIRE(m1.triangles == m0.triangles);
        REQUIRE(m1.positions.size() == m0.positions.size());
        double worst = 0.0;
        std::size_t moved_inside = 0;
        for (std::size_t i = 0; i < m0.positions.size(); ++i) {
            const double shift = (i % 3 == std::size_t(axis)) ? double(T) : 0.0;
            // m0's own rounding (|x| < 8: below 2^-20) is far under the spacing at 3125.
            const double d = std::fabs(double(m1.positions[i]) - (double(m0.positions[i]) + shift));
            worst = std::max(worst, d);
            moved_inside += d > 0.5 * ulp + 1e-6 * r;
        }
        INFO("largest deviation " << worst / ulp << " float spacings (" << worst / r << " r); " << moved_inside
                                  << " of " << m0.positions.size() << " coordinates beyond half a spacing");
        CHECK(worst <= 1.5 * ulp);
        CHECK(moved_inside * 200 <= m0.positions.size());  // under 0.5%
    }
}

TEST_CASE("far from the origin no two vertices share a position and no triangle is flat", "[e2e][precision]") {
    // A crossing within a float step of its edge's end rounded onto it, as the crossings of the
    // other edges there could: distinct vertices on one point and zero-area triangles, so the mesh
    // was closed by index but not once coincident vertices were welded (frame 23 moved 3e3 units:
    // 29 shared positions, 5 non-manifold edges after welding; 1e4 units: 178).
    const float r = 0.025f;
    ParticleSet s = generate_scene("pool-and-drop", r, 5);
    for (const double offset : {0.0, 1e3, 3e3, 1e4}) {
        INFO("offset " << offset);
        std::vector<float> moved = s.positions;
        for (float& c : moved) c = float(double(c) + offset);
        const Mesh m = shared_reconstructor().reconstruct(moved.data(), s.size(), params(r, Mode::Adaptive));
        require_closed(m, "pool-and-drop far away");
        std::vector<std::array<float, 3>> p(m.vertex_count());
        for (std::size_t v = 0; v < p.size(); ++v) p[v] = {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
        std::sort(p.begin(), p.end());
        CHECK(std::adjacent_find(p.begin(), p.end()) == p.end());
        std::size_t flat = 0;
        for (std::size_t t = 0; t < m.triangle_count(); ++t) {
            glm::dvec3 q[3];
            for (int k = 0; k < 3; ++k) q[k] = glm::dvec3(glm::make_vec3(&m.positions[3 * m.triangles[3 * t + std::size_t(k)]]));
            flat += glm::length(glm::cross(q[1] - q[0], q[2] - q[0])) == 0.0;
        }
        CHECK(flat == 0);
    }
}
