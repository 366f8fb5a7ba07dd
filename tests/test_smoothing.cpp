// Smoothing and sliver cleanup (host/mesh_smoothing.hpp, host/sliver_cleanup.hpp): topology kept on
// many random meshes, the analytic bodies' measures against their exact surfaces, determinism
// across thread counts, the real frames' droplets and volume, and the normals of a smoothed mesh.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <tbb/global_control.h>

#include "mesh_quality.hpp"
#include "mesh_test_support.hpp"
#include "mesh_smoothing.hpp"
#include "mesh_topology.hpp"
#include "sliver_cleanup.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"
#include "vertex_data.hpp"

using namespace trilevel;

namespace {

Reconstructor& reconstructor() {
    static Reconstructor rec;
    return rec;
}

Params params(float r, bool smooth = false) {
    Params p;
    p.particle_radius = r;
    p.smooth = smooth;
    return p;
}

std::vector<long long> sorted_euler(const Mesh& m) {
    auto chi = euler_characteristics(m, mesh_components(m));
    std::sort(chi.begin(), chi.end());
    return chi;
}

glm::dvec3 corner(const Mesh& m, std::size_t t, int k) {
    const std::size_t v = m.triangles[3 * t + k];
    return {m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]};
}

glm::dvec3 face_normal(const Mesh& m, std::size_t t) {
    return glm::cross(corner(m, t, 1) - corner(m, t, 0), corner(m, t, 2) - corner(m, t, 0));
}

/// A random fluid: a few jittered balls and slabs of random sizes, some splash particles and thin
/// jets, from a seed (SplitMix-free: the scene generator's scenes cover the lattices; these cover
/// irregular shapes and merging blobs).
std::vector<float> random_fluid(unsigned seed, float r) {
    std::uint64_t s = 0x9e3779b97f4a7c15ull * (seed + 1);
    auto next = [&] {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        return double(s >> 11) * 0x1.0p-53;
    };
    std::vector<float> xyz;
    const double h = 2.0 * r;
    const int blobs = 2 + int(4 * next());
    for (int b = 0; b < blobs; ++b) {
        const glm::dvec3 c(30 * next(), 30 * next(), 30 * next());
        const double radius = 1.5 + 7 * next();
        const int n = int(radius) + 1;
        for (int i = -n; i <= n; ++i)
            for (int j = -n; j <= n; ++j)
                for (int k = -n; k <= n; ++k)
                    if (i * i + j * j + k * k <= radius * radius)
                        for (double v : {c.x + i, c.y + j, c.z + k}) xyz.push_back(float((v + 0.5 * (next() - 0.5)) * h));
    }
    for (int k = 0; k < 10; ++k)  // splash particles and short jets
        for (int len = 1 + int(5 * next()), i = 0; i < len; ++i)
            for (double v : {35.0 + 3 * k, 5.0 + i, 35.0}) xyz.push_back(float(v * h));
    return xyz;
}

}  // namespace

TEST_CASE("sliver cleanup and smoothing keep random meshes closed, their components' Euler characteristics, and turn no triangle over",
          "[smoothing]") {
    const float r = 0.025f;
    std::size_t meshes = 0, collapsed = 0;
    auto check = [&](const std::vector<float>& xyz, Mode mode, const std::string& what) {
        INFO(what);
        Params p = params(r);
        p.mode = mode;
        const Mesh m0 = reconstructor().reconstruct(xyz.data(), xyz.size() / 3, p);
        REQUIRE(is_closed_and_oriented(m0));
        const auto chi0 = sorted_euler(m0);
        Mesh m = m0;
        collapsed += collapse_slivers(m);
        REQUIRE(is_closed_and_oriented(m));
        CHECK(sorted_euler(m) == chi0);
        CHECK(m.vertex_level.size() == m.vertex_count());
        CHECK(m.triangle_kind.size() == m.triangle_count());
        const Mesh before = m;
        const MeshComponents comp = mesh_components(before);
        const std::vector<double> vol0 = component_volumes(before, comp);
        SmoothingSettings settings;
        settings.iterations = kDefaultSmoothIterations;
        settings.min_volume = smooth_min_volume(r);
        smooth_mesh(m, smoothing_weights(m.positions, vertex_particle_grid(xyz.data(), xyz.size() / 3, r, 4 * r), r, 4 * r), settings);
        REQUIRE(m.triangles == before.triangles);  // positions only
        REQUIRE(is_closed_and_oriented(m));
        CHECK(sorted_euler(m) == chi0);
        std::size_t turned = 0;
        for (std::size_t t = 0; t < m.triangle_count(); ++t) {
            const glm::dvec3 a = face_normal(before, t);
            if (a != glm::dvec3(0.0)) turned += glm::dot(a, face_normal(m, t)) <= 0.0;
        }
        CHECK(turned == 0);
        const std::vector<double> vol = component_volumes(m, comp);
        for (std::size_t c = 0; c < comp.count; ++c) CHECK(std::fabs(vol[c] - vol0[c]) <= 1e-3 * std::fabs(vol0[c]) + 1e-12);
        ++meshes;
    };
    for (unsigned seed = 0; seed < 12; ++seed) check(random_fluid(seed, r), seed % 3 ? Mode::Adaptive : Mode::Uniform, "random fluid " + std::to_string(seed));
    for (const char* scene : {"ball", "torus", "rounded-box", "pool-and-drop", "dam-break"})
        for (std::uint64_t seed : {21u, 22u})
            check(generate_scene(scene, r, seed).positions, Mode::Adaptive, std::string(scene) + " seed " + std::to_string(seed));
    CHECK(meshes == 22);
    CHECK(collapsed > 0);  // the cleanup had work to do
}

TEST_CASE("smoothed analytic bodies against their exact surfaces (seeds never used for tuning)", "[smoothing]") {
    const float r = 0.025f;
    struct Case {
        const char* scene;
        double normal_deg, surface_r;  // bounds: the targets for the ball and torus; the box's, measured plus margin
        double normal_gain;            // smoothed against raw normal rms, at most (bench/RESULTS-smoothing.md)
    };
    for (const Case& c : {Case{"ball", 2.5, 0.10, 0.2}, Case{"torus", 3.0, 0.14, 0.25}, Case{"rounded-box", 11.5, 0.75, 0.9}})
        for (std::uint64_t seed : {3u, 11u}) {
            INFO(c.scene << " seed " << seed);
            const ParticleSet s = generate_scene(c.scene, r, seed);
            const AnalyticBody body = *analytic_body(c.scene, r);
            const Mesh raw = reconstructor().reconstruct(s.positions.data(), s.size(), params(r));
            const Mesh smooth = reconstructor().reconstruct(s.positions.data(), s.size(), params(r, true));
            const MeshQuality q0 = mesh_quality(raw, r, s.size(), &body), q = mesh_quality(smooth, r, s.size(), &body);
            INFO("normal rms " << q0.normal_rms_deg << " -> " << q.normal_rms_deg << " deg, surface rms " << q0.surface_rms
                               << " -> " << q.surface_rms << " r, slivers " << q0.sliver_share << " -> " << q.sliver_share
                               << ", volume " << q0.volume << " -> " << q.volume);
            CHECK(q.closed);
            CHECK(q.components == 1);
            CHECK(q.euler == q0.euler);
            CHECK(q.normal_rms_deg <= c.normal_deg);
            CHECK(q.normal_rms_deg <= c.normal_gain * q0.normal_rms_deg);
            CHECK(q.surface_rms <= c.surface_r);
            CHECK(q.sliver_share <= 0.005);
            CHECK(std::fabs(q.volume / q0.volume - 1.0) <= 0.01);
            CHECK(q.triangles <= q0.triangles);
        }
}

TEST_CASE("long smoothing runs keep a droplet round and its volume", "[smoothing]") {
    // Laplacian steps shrink a body along its curvature: a droplet of radius 8r to a fraction of
    // its volume in 100 steps. Restored only at the end, it came out at a tenth of its volume and
    // twice as wide (a crumpled mesh); a long run now restores the volumes as it goes.
    const float r = 0.025f;
    std::vector<glm::vec3> ball;
    for (const glm::vec3& p : test::lattice_points(glm::ivec3(17), glm::vec3(-16 * r), 2 * r, 0.1f * r, 9))
        if (glm::length(p) <= 8.0f * r) ball.push_back(p + glm::vec3(1.0f));
    const Mesh raw = reconstructor().reconstruct(&ball[0].x, ball.size(), params(r));
    const double v0 = test::signed_volume(raw);
    for (int iterations : {100, 1000}) {
        INFO(iterations << " Laplacian steps");
        Params p = params(r, true);
        p.smooth_iterations = iterations;
        const Mesh m = reconstructor().reconstruct(&ball[0].x, ball.size(), p);
        CHECK(is_closed_and_oriented(m));
        CHECK(mesh_components(m).count == 1);
        CHECK(test::signed_volume(m) == Approx(v0).epsilon(1e-4));
        // Round: every vertex within 0.75 r of the radius of a ball of that volume (0.64 r at most
        // after 1000 steps, 0.39 r after 100; before, vertices lay many r out).
        double off = 0.0;
        for (std::size_t v = 0; v < m.vertex_count(); ++v)
            off = std::max(off, std::fabs(glm::distance(glm::dvec3(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]),
                                                        glm::dvec3(1.0)) - std::cbrt(3.0 * v0 / (4.0 * 3.14159265358979))));
        INFO("farthest from the ball's radius " << off / r << " r");
        CHECK(off < 0.75 * r);
    }
}

TEST_CASE("smoothing gives the same bits on 1 and 2 threads", "[smoothing]") {
    const float r = 0.025f;
    const ParticleSet s = generate_scene("pool-and-drop", r, 5);
    Params p = params(r, true);
    p.normals = NormalMode::Gradient;
    Mesh one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = reconstructor().reconstruct(s.positions.data(), s.size(), p);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = reconstructor().reconstruct(s.positions.data(), s.size(), p);
    }
    REQUIRE(one.positions.size() == two.positions.size());
    CHECK(std::memcmp(one.positions.data(), two.positions.data(), one.positions.size() * sizeof(float)) == 0);
    CHECK(one.triangles == two.triangles);
    CHECK(std::memcmp(one.normals.data(), two.normals.data(), one.normals.size() * sizeof(float)) == 0);
}

TEST_CASE("smoothing off leaves the mesh as it was, and sliver cleanup alone only removes needles", "[smoothing]") {
    const float r = 0.025f;
    const ParticleSet s = generate_scene("ball", r, 4);
    const Mesh plain = reconstructor().reconstruct(s.positions.data(), s.size(), params(r));
    Params off = params(r);
    off.smooth_iterations = 7;  // without smooth: no effect
    const Mesh same = reconstructor().reconstruct(s.positions.data(), s.size(), off);
    CHECK(same.positions == plain.positions);
    CHECK(same.triangles == plain.triangles);
    Params cleanup = params(r);
    cleanup.sliver_cleanup = true;
    Stats st;
    const Mesh cleaned = reconstructor().reconstruct(s.positions.data(), s.size(), cleanup, &st);
    CHECK(st.closed);
    CHECK(st.sliver_edges_collapsed > 0);
    CHECK(cleaned.triangle_count() == plain.triangle_count() - 2 * st.sliver_edges_collapsed);
    CHECK(st.triangles == cleaned.triangle_count());
    const MeshQuality q0 = mesh_quality(plain, r, 0, nullptr), q = mesh_quality(cleaned, r, 0, nullptr);
    CHECK(q.sliver_share < 0.5 * q0.sliver_share);
    CHECK(std::fabs(q.volume / q0.volume - 1.0) < 1e-3);
    bool timed = false;
    for (const auto& [name, ms] : st.time_ms) timed |= name == "sliver_cleanup";
    CHECK(timed);
}

TEST_CASE("normals of a smoothed mesh are its area-weighted normals and agree with its faces", "[smoothing][normals]") {
    const float r = 0.025f;
    const ParticleSet s = generate_scene("torus", r, 2);
    for (NormalMode mode : {NormalMode::Gradient, NormalMode::Area}) {
        Params p = params(r, true);
        p.normals = mode;
        const Mesh m = reconstructor().reconstruct(s.positions.data(), s.size(), p);
        REQUIRE(m.normals.size() == m.positions.size());
        CHECK(m.normals == area_weighted_normals(m));
        // The vertex normals agree with the faces around them: within 90 degrees of each adjacent
        // face's normal at all but a few corners (measured: 15 of 44,184 corners on this torus, in
        // creases where a face leans over its neighbours), and always with their sum.
        std::size_t disagree = 0, corners = 0;
        for (std::size_t t = 0; t < m.triangle_count(); ++t) {
            const glm::dvec3 f = face_normal(m, t);
            for (int k = 0; k < 3; ++k) {
                const std::size_t v = m.triangles[3 * t + k];
                disagree += glm::dot(f, glm::dvec3(m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2])) <= 0.0;
                ++corners;
            }
        }
        CHECK(disagree <= corners / 1000);
        for (std::size_t v = 0; v < m.vertex_count(); ++v)
            CHECK(std::fabs(m.normals[3 * v] * m.normals[3 * v] + m.normals[3 * v + 1] * m.normals[3 * v + 1] +
                            m.normals[3 * v + 2] * m.normals[3 * v + 2] - 1.0f) < 1e-5f);
    }
}

TEST_CASE("smoothing rejects bad iteration counts with one clear line", "[smoothing]") {
    const ParticleSet s = generate_scene("ball", 0.025f, 1);
    Params p = params(0.025f, true);
    p.smooth_iterations = -1;
    CHECK_THROWS_WITH(reconstructor().reconstruct(s.positions.data(), s.size(), p),
                      "smooth iterations must lie in [0, 1000] (0: the default 12), got -1");
    p.smooth_iterations = 1001;
    CHECK_THROWS_WITH(reconstructor().reconstruct(s.positions.data(), s.size(), p),
                      "smooth iterations must lie in [0, 1000] (0: the default 12), got 1001");
}

TEST_CASE("smoothing the dam-break frames keeps their droplets, their volume and a closed mesh", "[smoothing][shared]") {
    TRILEVEL_REQUIRE_SHARED_DATA(dir);
    const float r = 0.025f;
    std::size_t frames = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
        const std::string name = e.path().filename().string();
        if (name.rfind("dam_break_frame_", 0) != 0) continue;
        INFO(name);
        const ParticleSet s = read_particles(e.path().string());
        const Mesh raw = reconstructor().reconstruct(s.positions.data(), s.size(), params(r));
        Stats st;
        const Mesh smooth = reconstructor().reconstruct(s.positions.data(), s.size(), params(r, true), &st);
        const MeshQuality q0 = mesh_quality(raw, r, s.size(), nullptr), q = mesh_quality(smooth, r, s.size(), nullptr);
        INFO("components " << q0.components << " -> " << q.components << ", volume " << q0.volume << " -> " << q.volume);
        CHECK(q.closed);
        CHECK(st.closed);
        CHECK(double(q.components) >= 0.95 * double(q0.components));
        CHECK(std::fabs(q.volume / q0.volume - 1.0) <= 0.02);
        CHECK(q.sliver_share <= 0.02);  // measured 1.27% on frame 23, in its thin sheets (the 0.5% target is the bodies')
        ++frames;
    }
    CHECK(frames == 2);
}

TEST_CASE("smoothing weights do not depend on the particle grid's cells or layout, and follow the kernel sum", "[smoothing][particle_grid]") {
    // Their sums run in an order of their own (mesh_smoothing.cpp, SumOrder): a grid of other cells
    // or the sorted layout must give the same bits, also in the transition band where the sums' last
    // bits can reach the weight.
    const float r = 0.025f, R = 4 * r;
    for (unsigned seed : {2u, 5u}) {
        const std::vector<float> xyz = random_fluid(seed, r);
        const std::size_t n = xyz.size() / 3;
        Params p = params(r);
        p.sliver_cleanup = true;
        const Mesh m = reconstructor().reconstruct(xyz.data(), n, p);
        const std::vector<float> w = smoothing_weights(m.positions, vertex_particle_grid(xyz.data(), n, r, R), r, R);
        REQUIRE(w.size() == m.vertex_count());
        for (float cell : {0.5f * R, 1.37f * R, 3.0f * R})
            for (std::size_t dense_limit : {std::size_t(0), std::size_t(1)}) {
                const std::vector<float> other = smoothing_weights(m.positions, ParticleGrid(xyz.data(), n, cell, dense_limit), r, R);
                REQUIRE(std::memcmp(other.data(), w.data(), w.size() * sizeof(float)) == 0);
            }
        // Against the brute-force kernel sum (any order: to rounding) and the documented ramp.
        const double flat = 0.5 * 0.7 * (4.0 * 3.141592653589793 * 16.0 / 315.0) * std::pow(double(R) / (2.0 * r), 3.0);
        std::size_t band = 0, one = 0;
        for (std::size_t v = 0; v < m.vertex_count(); ++v) {
            const glm::dvec3 q(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]);
            double sum = 0.0;
            for (std::size_t j = 0; j < n; ++j) {
                const glm::dvec3 d = q - glm::dvec3(xyz[3 * j], xyz[3 * j + 1], xyz[3 * j + 2]);
                const double u = 1.0 - glm::dot(d, d) / (double(R) * R);
                if (u > 0.0) sum += u * u * u;
            }
            const double x = std::clamp((sum / flat - 0.45) / 0.35, 0.0, 1.0);
            REQUIRE(w[v] == Approx(x * x * (3.0 - 2.0 * x)).margin(1e-6));
            band += w[v] > 0.0f && w[v] < 1.0f;
            one += w[v] == 1.0f;
        }
        CHECK(band > 100);  // the fallback's vertices are exercised
        CHECK(one > 100);
    }
}

TEST_CASE("smoothing weights taken beside the crack collapse give the mesh of the weights taken after it", "[smoothing]") {
    // One unscaled lattice: the weights are computed on the vertices before the crack collapse,
    // beside it. Lengths scaled by 2^-20 (r = 2.4e-8, outside the float kernels' band) take the
    // scaled path, where they are computed after the collapses; every step scales exactly by a
    // power of two, so the meshes must agree bit for bit.
    const float r = 0.025f;
    std::size_t cracks = 0, slivers = 0, partial = 0;
    for (int scene = 0; scene < 5; ++scene) {
        // Random fluids (splashes: many weights between 0 and 1) and two generated scenes.
        const std::vector<float> positions = scene < 3 ? random_fluid(unsigned(scene), r)
                                                       : generate_scene(scene == 3 ? "pool-and-drop" : "torus", r, 3).positions;
        INFO("scene " << scene);
        ParticleSet s;
        s.positions = positions;
        Stats a, b;
        Params p = params(r, true), q = p;
        p.curvature_threshold = 1.0f;  // more level-3 cells: more transitions, more crack collapses
        const Mesh base = reconstructor().reconstruct(s.positions.data(), s.size(), p, &a);
        {
            Params raw_params = p;
            raw_params.smooth = false;
            const Mesh raw = reconstructor().reconstruct(s.positions.data(), s.size(), raw_params);
            for (float w : smoothing_weights(raw.positions, vertex_particle_grid(s.positions.data(), s.size(), r, 4 * r), r, 4 * r))
                partial += w > 0.0f && w < 1.0f;
        }
        cracks += a.crack_vertices_collapsed;
        slivers += a.sliver_edges_collapsed;
        std::vector<float> x = s.positions;
        for (float& v : x) v = std::ldexp(v, -20);
        q = p;
        q.particle_radius = std::ldexp(r, -20);
        const Mesh scaled = reconstructor().reconstruct(x.data(), s.size(), q, &b);
        REQUIRE(scaled.triangles == base.triangles);
        std::vector<float> back = scaled.positions;
        for (float& v : back) v = std::ldexp(v, 20);
        REQUIRE(back == base.positions);
        CHECK(b.smoothing_reverted_moves == a.smoothing_reverted_moves);
    }
    CHECK(cracks > 0);  // the collapse the weights ran beside had work
    CHECK(slivers > 0);
    CHECK(partial > 100);  // weights that a wrong vertex would get wrong
}
