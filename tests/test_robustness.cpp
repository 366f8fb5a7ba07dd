// Robustness: absurd parameters are one-line errors naming the parameter, extreme but
// legal particle sets give closed meshes in bounded time, domains too wide for one lattice are
// split, OpenCL failures name the stage and leave the Reconstructor usable.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "mesh_test_support.hpp"
#include "device_test_support.hpp"
#include "opencl_runtime.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"
#include "trilevel/trilevel.hpp"

using namespace trilevel;

using trilevel::test::require_closed;
using trilevel::test::frame_memory_need;
using trilevel::test::same_mesh;
using trilevel::test::ScopedEnv;
using trilevel::test::settled_unpooled_buffers;

namespace {

Reconstructor& robust_reconstructor() {
    static Reconstructor rec;
    return rec;
}

Params with_radius(float r) {
    Params p;
    p.particle_radius = r;
    return p;
}

/// The API must throw one line naming `name` and giving `why`.
void require_param_error(const std::vector<float>& xyz, const Params& p, const std::string& name, const std::string& why,
                         int& counted) {
    INFO("expecting an error about " << name << " (" << why << ")");
    try {
        robust_reconstructor().reconstruct(xyz.data(), xyz.size() / 3, p);
        FAIL("no error");
    } catch (const Error& e) {
        const std::string msg = e.what();
        INFO("message: " << msg);
        CHECK(msg.find(name) != std::string::npos);
        CHECK(msg.find(why) != std::string::npos);
        CHECK(msg.find('\n') == std::string::npos);
    }
    ++counted;
}

}  // namespace

TEST_CASE("absurd parameters are one-line errors naming the parameter and why", "[robust][params]") {
    const ParticleSet scene = generate_scene("pool-and-drop", 0.025f, 1);
    const std::vector<float>& x = scene.positions;
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    int counted = 0;
    for (float r : {0.0f, -0.025f, nan, inf, -inf})
        require_param_error(x, with_radius(r), "particle radius", "must be finite and > 0", counted);
    // 1e-30 is below what float coordinates near 1 resolve; 1e30 (and 1e3) put all 30,356
    // particles within one kernel radius of each other.
    require_param_error(x, with_radius(1e-30f), "particle radius", "cannot resolve", counted);
    require_param_error(x, with_radius(1e-9f), "particle radius", "cannot resolve", counted);
    require_param_error(x, with_radius(1e30f), "particle radius", "too large", counted);
    require_param_error(x, with_radius(1e3f), "particle radius", "too large", counted);
    for (float k : {0.0f, -4.0f, nan, inf}) {
        Params p = with_radius(0.025f);
        p.kernel_radius = k;
        require_param_error(x, p, "kernel radius", "must be finite and > 0", counted);
    }
    for (float k : {0.5f, 17.0f, 1e30f}) {
        Params p = with_radius(0.025f);
        p.kernel_radius = k;
        require_param_error(x, p, "kernel radius", "[1, 16]", counted);
    }
    for (float c : {0.0f, -1.0f, nan, inf}) {
        Params p = with_radius(0.025f);
        p.mode = Mode::Uniform;
        p.cell = c;
        require_param_error(x, p, "cell size", "must be finite and > 0", counted);
    }
    // 4/cell must be an even whole number up to 64: 4 (n = 1), 0.8 (5), 4/3 (3) and 1/32 (128) are not.
    for (float c : {3.0f, 0.3f, 8.0f, 1e-30f, 4.0f, 0.8f, 4.0f / 3.0f, 0.03125f}) {
        Params p = with_radius(0.025f);
        p.mode = Mode::Uniform;
        p.cell = c;
        require_param_error(x, p, "cell size", "must be 4/n radii for an even n from 2 to 64", counted);
    }
    for (float t : {-1.0f, nan, inf}) {
        Params p = with_radius(0.025f);
        p.curvature_threshold = t;
        require_param_error(x, p, "curvature threshold", "must be finite and > 0", counted);
    }
    for (float t : {-0.5f, nan, inf}) {
        Params p = with_radius(0.025f);
        p.level2_tolerance = t;
        require_param_error(x, p, "level-2 tolerance", "must be finite and >= 0", counted);
    }
    for (std::uint64_t bytes : {1ull, 4095ull}) {
        Params p = with_radius(0.025f);
        p.memory_limit_bytes = bytes;
        require_param_error(x, p, "memory limit", "at least 4 KiB", counted);
    }
    {  // legal but far too small for the frame: the budget check names what did not fit
        Params p = with_radius(0.025f);
        p.memory_limit_bytes = 64 * 1024;
        require_param_error(x, p, "budget", "use a larger cell or a smaller domain", counted);
    }
    CHECK(counted == 37);
    std::printf("absurd parameter sets rejected through the API: %d\n", counted);
}

// A pile on one point is refused by the neighbour-work check, which sees the counted bins before
// the particles are sorted into them (test_device_stages.cpp: a 20 M pile sorted its one bin for
// over 150 s before the refusal; now it takes under a second).
TEST_CASE("a pile of 2 million particles on one point is refused and the Reconstructor stays usable", "[robust][params]") {
    const float spot[3] = {0.5f, 1.25f, -2.0f};
    std::vector<float> pile;
    pile.reserve(3 * 2000000);
    for (int i = 0; i < 2000000; ++i) pile.insert(pile.end(), spot, spot + 3);
    const auto start = std::chrono::steady_clock::now();
    int counted = 0;
    require_param_error(pile, with_radius(0.025f), "particle radius 0.025", "others within one kernel radius", counted);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    CHECK(seconds < 60.0);  // a hang guard: a fifth of a second here
    // The Reconstructor is still usable.
    require_closed(robust_reconstructor().reconstruct(spot, 1, with_radius(0.025f)), "a single particle after the pile");
}

// A radius far too small leaves every particle alone: each becomes a droplet of its own on the r
// lattice (about 9.6 KB each). 4.1 M particles 20 r apart ran 50 s before a buffer failed with
// advice about the cell size; such frames are now refused after the colour field, naming the radius.
TEST_CASE("particles far apart for their radius are refused up front when their droplets exceed the budget", "[robust][memory]") {
    const float r = 0.005f;
    std::vector<float> apart;
    for (const glm::vec3& p : test::lattice_points({30, 30, 30}, {0.1f, 0.2f, 0.3f}, 20 * r)) apart.insert(apart.end(), {p.x, p.y, p.z});
    Params tight = with_radius(r);
    tight.memory_limit_bytes = 100u << 20;  // 27 k lone particles need ~220 MB
    int counted = 0;
    require_param_error(apart, tight, "particle radius 0.005", "probably too small", counted);
    require_param_error(apart, tight, "27000 of 27000 particles", "fewer than 3 others within the kernel radius", counted);
    // Within the budget they are meshed: one droplet each.
    const std::vector<float> few(apart.begin(), apart.begin() + 3 * 1000);
    Stats st;
    const Mesh m = robust_reconstructor().reconstruct(few.data(), 1000, tight, &st);
    require_closed(m, "1000 lone particles");
    CHECK(st.splash_particles == 1000);
}

TEST_CASE("radii outside the float kernels' band are scaled by a power of two, exactly", "[robust][params]") {
    // The same sphere with every length scaled by 2^-20 and 2^+12: r = 2.4e-8 and 102 world units.
    // R^9 under- or overflows single precision there; the pipeline runs on lengths scaled back
    // into range, so the mesh is the r = 0.025 mesh scaled by the same power of two, bit for bit.
    const ParticleSet s = generate_scene("sphere", 0.025f, 2);
    auto& rec = robust_reconstructor();
    const Mesh base = rec.reconstruct(s.positions.data(), s.size(), with_radius(0.025f));
    require_closed(base, "r = 0.025");
    for (int e : {-20, 12}) {
        INFO("scale 2^" << e);
        std::vector<float> x = s.positions;
        for (float& v : x) v = std::ldexp(v, e);
        const Mesh m = rec.reconstruct(x.data(), s.size(), with_radius(std::ldexp(0.025f, e)));
        REQUIRE(m.triangles == base.triangles);
        std::vector<float> back = m.positions;
        for (float& v : back) v = std::ldexp(v, -e);
        REQUIRE(back == base.positions);
    }
}

TEST_CASE("extreme but legal particle sets give closed meshes in bounded time", "[robust][extreme]") {
    auto& rec = robust_reconstructor();
    const float r = 0.025f;
    const auto start = std::chrono::steady_clock::now();
    const float one[3] = {1.013f, 2.007f, 3.011f};
    const Mesh single = rec.reconstruct(one, 1, with_radius(r));
    require_closed(single, "a single particle");

    SECTION("1000 particles on one point are the single particle's blob") {
        // They have no colour-field gradient at all; counted as one spot they are a splash particle.
        std::vector<float> pile;
        for (int i = 0; i < 1000; ++i) pile.insert(pile.end(), one, one + 3);
        Stats st;
        const Mesh m = rec.reconstruct(pile.data(), 1000, with_radius(r), &st);
        require_closed(m, "1000 particles on one point");
        CHECK(st.splash_particles == 1000);
        // The field is |x - p| - r on both (the weights only scale): same triangles, positions equal
        // up to the rounding of the 1000-term weighted mean.
        REQUIRE(m.triangles == single.triangles);
        for (std::size_t i = 0; i < m.positions.size(); ++i) REQUIRE(std::fabs(m.positions[i] - single.positions[i]) < 1e-3f * r);
    }
    SECTION("two particles 10^4 r apart are two blobs") {
        const float two[6] = {one[0], one[1], one[2], one[0] + 1e4f * r, one[1], one[2]};
        const Mesh m = rec.reconstruct(two, 2, with_radius(r));
        require_closed(m, "two particles 1e4 r apart");
        CHECK(m.triangle_count() >= 2 * 8);  // two separate closed blobs (an octahedron at least)
        std::size_t near = 0;
        for (std::size_t v = 0; v < m.vertex_count(); ++v) near += std::fabs(m.positions[3 * v] - one[0]) < 2 * r;
        CHECK(near > 0);
        CHECK(near < m.vertex_count());
    }
    SECTION("particles spread over 10^6 r, adaptive (one lattice) and cell r/2 (split lattices)") {
        // 200 particles at multiples of the coarse cell plus one offset, all exact in float (r = 2^-5):
        // every blob sees the same lattice around it, so the mesh is exactly 200 copies of one blob.
        const float r2 = 0.03125f, edge = 4 * r2;
        const float offset[3] = {11.0f / 256, 19.0f / 256, 5.0f / 256};
        std::vector<float> spread;
        std::uint64_t seed = 12345;
        auto next = [&] { return (seed = seed * 6364136223846793005ull + 1442695040888963407ull) >> 33; };
        for (int i = 0; i < 200; ++i)
            for (int a = 0; a < 3; ++a) spread.push_back(float(next() % 250000) * edge + offset[a]);
        for (float cell : {0.0f, 0.5f}) {
            INFO("cell " << cell);
            Params p = with_radius(r2);
            if (cell > 0) {
                p.mode = Mode::Uniform;
                p.cell = cell;
            }
            std::vector<float> lone = {spread[0], spread[1], spread[2]};
            const Mesh blob = rec.reconstruct(lone.data(), 1, p);
            Stats st;
            const Mesh m = rec.reconstruct(spread.data(), 200, p, &st);
            require_closed(m, "200 particles over 1e6 r");
            CHECK(m.triangle_count() == 200 * blob.triangle_count());
            CHECK(st.surface_cells == 200 * 8);
            CHECK(st.peak_memory_bytes < (std::uint64_t(1) << 30));  // memory follows the particles
        }
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    CHECK(seconds < 60.0);
}

TEST_CASE("a domain split into per-cluster lattices gives the single-lattice mesh", "[robust][split]") {
    // Three balls of radius 8r, 60r apart, and a lone particle: four clusters. With the lattice
    // capacity lowered to 80 steps (test hook), they no longer fit one lattice and are reconstructed
    // on lattices of their own; the cells and fine points are the same ones.
    const float r = 0.025f;
    std::vector<float> x;
    for (int b = 0; b < 3; ++b)
        for (int k = -4; k <= 4; ++k)
            for (int j = -4; j <= 4; ++j)
                for (int i = -4; i <= 4; ++i)
                    if (i * i + j * j + k * k <= 16)
                        x.insert(x.end(), {(60.0f * b + 2.0f * i + 0.37f + 0.01f * float((i * 7 + j * 3 + k) % 5)) * r + 1.0f,
                                           (2.0f * j + 0.21f + 0.013f * float((j * 5 + k) % 3)) * r + 2.0f,
                                           (2.0f * k + 0.13f) * r + 3.0f});
    x.insert(x.end(), {30.37f * r + 1.0f, 40.21f * r + 2.0f, 0.13f * r + 3.0f});
    const std::size_t n = x.size() / 3;
    auto& rec = robust_reconstructor();
    Stats whole_stats, split_stats;
    const Mesh whole = rec.reconstruct(x.data(), n, with_radius(r), &whole_stats);
    Mesh split;
    {
        ScopedEnv env("TRILEVEL_MAX_LATTICE_STEPS", "80");
        split = rec.reconstruct(x.data(), n, with_radius(r), &split_stats);
    }
    require_closed(whole, "one lattice");
    require_closed(split, "split domain");
    CHECK(split_stats.particles == n);
    CHECK(split_stats.surface_particles == whole_stats.surface_particles);
    CHECK(split_stats.surface_cells == whole_stats.surface_cells);
    CHECK(split_stats.fine_points == whole_stats.fine_points);
    CHECK(split.triangle_count() == whole.triangle_count());
    const double v = test::signed_volume(whole);
    CHECK(std::fabs(test::signed_volume(split) - v) < 1e-5 * v);

    // One connected body wider than a lattice is an error, not a wrong mesh.
    const ParticleSet pool = generate_scene("pool-and-drop", r, 3);  // a pool 120 r wide
    ScopedEnv env("TRILEVEL_MAX_LATTICE_STEPS", "100");
    REQUIRE_THROWS_WITH(rec.reconstruct(pool.positions.data(), pool.size(), with_radius(r)),
                        Catch::Contains("connected body of particles spans") && Catch::Contains("use a larger cell"));
}

TEST_CASE("an OpenCL failure in any stage is a clear error and the Reconstructor stays usable", "[robust][opencl]") {
    const float r = 0.025f;
    const ParticleSet s = generate_scene("pool-and-drop", r, 5);
    auto& rec = robust_reconstructor();
    const Mesh expected = rec.reconstruct(s.positions.data(), s.size(), with_radius(r));
    // A Reconstructor's first frame pools nothing (OpenCLRuntime::end_frame); from the second on it does.
    REQUIRE(same_mesh(rec.reconstruct(s.positions.data(), s.size(), with_radius(r)), expected));
    REQUIRE(settled_unpooled_buffers() == 0);  // between frames a Reconstructor holds only its pool
    const std::int64_t pooled = pooled_device_bytes();
    std::int64_t others = -1;  // pooled by other Reconstructors of the process, once rec's pool is gone
    for (const char* stage :
         {"binning", "surface_particles", "surface_cells", "scalar_field", "band_closure", "edge_refinement", "triangulation"}) {
        INFO("stage " << stage);
        {
            ScopedEnv env("TRILEVEL_FAULT", stage);
            try {
                rec.reconstruct(s.positions.data(), s.size(), with_radius(r));
                FAIL("no error");
            } catch (const Error& e) {
                const std::string msg = e.what();
                INFO(msg);
                CHECK(msg.find(std::string("stage ") + stage + ":") != std::string::npos);
                CHECK(msg.find("CL_OUT_OF_RESOURCES") != std::string::npos);
                CHECK(msg.find("use a larger cell") != std::string::npos);
            }
        }
        CHECK(settled_unpooled_buffers() == 0);  // nothing held after the failure...
        if (others < 0) others = pooled_device_bytes();
        CHECK(pooled_device_bytes() == others);  // ...not even the pool, which a failure releases
        CHECK(others < pooled);
        const Mesh again = rec.reconstruct(s.positions.data(), s.size(), with_radius(r));
        REQUIRE(same_mesh(again, expected));
    }
}

TEST_CASE("a growing fine-point table past the memory budget is an error naming the budget", "[robust][memory]") {
    const float r = 0.025f;
    const ParticleSet s = generate_scene("sphere", r, 1);
    auto& rec = robust_reconstructor();
    Stats st;
    const Mesh m = rec.reconstruct(s.positions.data(), s.size(), with_radius(r), &st);
    REQUIRE(st.device_memory_bytes > 0);
    // Budgets between "nothing fits" and "everything fits": each must fail cleanly in some stage.
    for (double f : {0.05, 0.3, 0.6, 0.9}) {
        Params p = with_radius(r);
        p.memory_limit_bytes = std::uint64_t(f * double(st.device_memory_bytes));
        INFO("budget " << p.memory_limit_bytes << " of " << st.device_memory_bytes);
        REQUIRE_THROWS_WITH(rec.reconstruct(s.positions.data(), s.size(), p),
                            Catch::Contains("over the budget") && Catch::Contains("use a larger cell or a smaller domain"));
    }
    Params enough = with_radius(r);
    enough.memory_limit_bytes = frame_memory_need(st);
    REQUIRE(same_mesh(rec.reconstruct(s.positions.data(), s.size(), enough), m));
}
