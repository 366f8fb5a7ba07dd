// Test scenes on jittered lattices (spacing 2r, y up), defined in lattice units so the
// particle count is independent of the radius. Jitter comes from splitmix64, not from <random>
// distributions, so a seed gives the same bytes with every standard library.
#include <algorithm>
#include <cmath>
#include <functional>

#include <glm/glm.hpp>

#include "analytic_bodies.hpp"
#include "trilevel/io.hpp"

namespace trilevel {
namespace {

class SplitMix64 {
public:
    explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
        return z ^ (z >> 31);
    }
    /// Uniform in [-1, 1).
    double symmetric() { return static_cast<double>(next() >> 11) * 0x1.0p-52 - 1.0; }
    /// Uniform in [0, 1).
    double unit() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

private:
    std::uint64_t state_;
};

constexpr double kJitter = 0.03;  // of the spacing

/// Collects particles given in lattice units (1 = one spacing) and scales them to world units.
class SceneBuilder {
public:
    SceneBuilder(float radius, std::uint64_t seed) : spacing_(2.0 * radius), rng_(seed) {}

    /// Adds a particle at lattice coordinates (x, y, z) plus jitter of `jitter` spacings.
    void add(double x, double y, double z, double jitter = kJitter) {
        const glm::dvec3 p = jittered(x, y, z, jitter);
        place(p.x, p.y, p.z);
    }

    /// (x, y, z) plus jitter of `jitter` spacings per axis, lattice units.
    glm::dvec3 jittered(double x, double y, double z, double jitter) {
        const double dx = jitter * rng_.symmetric(), dy = jitter * rng_.symmetric(), dz = jitter * rng_.symmetric();
        return {x + dx, y + dy, z + dz};
    }

    /// Adds a particle at exactly (x, y, z), lattice units.
    void place(double x, double y, double z) {
        for (double c : {x, y, z}) out_.positions.push_back(static_cast<float>(c * spacing_));
    }

    /// Every lattice point of the box [x0, x0+nx) x ... for which keep(i, j, k) holds.
    void box(int x0, int y0, int z0, int nx, int ny, int nz,
             const std::function<bool(int, int, int)>& keep = nullptr) {
        for (int j = 0; j < ny; ++j)
            for (int k = 0; k < nz; ++k)
                for (int i = 0; i < nx; ++i)
                    if (!keep || keep(i, j, k)) add(x0 + i, y0 + j, z0 + k);
    }

    /// A ball of lattice points within diameter/2 of the centre of a diameter^3 box at (x0, y0, z0).
    void ball(int x0, int y0, int z0, int diameter) {
        const double c = 0.5 * (diameter - 1), r = 0.5 * diameter;
        box(x0, y0, z0, diameter, diameter, diameter, [&](int i, int j, int k) {
            return (i - c) * (i - c) + (j - c) * (j - c) + (k - c) * (k - c) <= r * r;
        });
    }

    SplitMix64& rng() { return rng_; }
    ParticleSet take() { return std::move(out_); }

private:
    double spacing_;
    SplitMix64 rng_;
    ParticleSet out_;
};

ParticleSet block(SceneBuilder& b) {
    b.box(0, 0, 0, 24, 24, 24);  // 13824 particles
    return b.take();
}

ParticleSet sphere(SceneBuilder& b) {
    b.ball(0, 0, 0, 30);  // about 14k particles
    return b.take();
}

/// A pool 48 x 5 x 32 and a column 14 x 28 x 14 in one corner whose top layers shear and scatter.
ParticleSet dam_break(SceneBuilder& b) {
    b.box(0, 0, 0, 48, 5, 32);
    const int top = 28;
    for (int j = 0; j < top; ++j)
        for (int k = 0; k < 14; ++k)
            for (int i = 0; i < 14; ++i) {
                const int above = j - (top - 5);  // the top 5 layers start to collapse
                const double shear = above > 0 ? 0.35 * above * above / 5.0 : 0.0;
                const double jitter = above > 0 ? kJitter + 0.04 * above : kJitter;
                b.add(i + shear, 5 + j, k, jitter);
            }
    return b.take();
}

/// A flat pool 60 x 8 x 60, a drop of diameter 14 falling onto it, a thin jet rising from it
/// and 12 isolated splash particles at least 6 spacings from everything else.
ParticleSet pool_and_drop(SceneBuilder& b) {
    b.box(0, 0, 0, 60, 8, 60);
    b.ball(16, 22, 16, 14);                // centre (22.5, 28.5, 22.5), well above the pool
    b.box(44, 8, 44, 2, 18, 2);            // jet: 2 x 2 particles thick, 18 high
    std::vector<double> taken;             // splash positions, lattice units
    auto far = [&](double x, double y, double z) {
        auto d2 = [&](double cx, double cy, double cz) { return (x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz); };
        if (y < 8 + 6) return false;                                  // pool top at y = 7
        if (std::sqrt(d2(22.5, 28.5, 22.5)) < 7 + 6) return false;  // drop
        if (std::fabs(x - 44.5) < 7 && std::fabs(z - 44.5) < 7 && y < 26 + 6) return false;  // jet
        for (std::size_t s = 0; s < taken.size(); s += 3)
            if (d2(taken[s], taken[s + 1], taken[s + 2]) < 36) return false;
        return true;
    };
    while (taken.size() < 3 * 12) {
        const double x = 60 * b.rng().unit(), y = 14 + 24 * b.rng().unit(), z = 60 * b.rng().unit();
        if (!far(x, y, z)) continue;
        taken.insert(taken.end(), {x, y, z});
        b.add(x, y, z, 0.0);
    }
    return b.take();
}

/// Lattice points of a ball of `diameter` points centred on the origin (as SceneBuilder::ball).
std::vector<glm::dvec3> ball_offsets(int diameter) {
    std::vector<glm::dvec3> out;
    const double c = 0.5 * (diameter - 1), r = 0.5 * diameter;
    for (int j = 0; j < diameter; ++j)
        for (int k = 0; k < diameter; ++k)
            for (int i = 0; i < diameter; ++i) {
                const glm::dvec3 d(i - c, j - c, k - c);
                if (glm::dot(d, d) <= r * r) out.push_back(d);
            }
    return out;
}

/// A moving scene for frame sequences, smooth in the frame number t (one frame = 1/30 s of
/// motion; lattice units): a pool 40 x 7 x 40 carrying two travelling waves, a drop of diameter 8
/// bouncing across it on ballistic arcs (period 100 frames), and six droplets of diameter 3
/// circling above it, whose curvature lies near the level threshold. Every particle also wobbles
/// by up to 0.05 spacings on its own period: as in a simulation, no two frames sample the
/// surfaces alike. Particle order and count are the same in every frame.
ParticleSet falling_drop(SceneBuilder& b, double t) {
    constexpr double kTau = 6.283185307179586;
    auto& rng = b.rng();
    // Per-particle wobble: static jitter, amplitude, period and phase drawn in particle order.
    auto wobbled = [&](glm::dvec3 p) {
        glm::dvec3 out = p;
        for (int a = 0; a < 3; ++a) {
            const double still = kJitter * rng.symmetric(), amplitude = 0.05 * rng.unit();
            const double period = 20.0 + 40.0 * rng.unit(), phase = kTau * rng.unit();
            out[a] += still + amplitude * std::sin(kTau * t / period + phase);
        }
        b.place(out.x, out.y, out.z);
    };
    constexpr int kPool = 40, kDepth = 7;
    for (int j = 0; j < kDepth; ++j)
        for (int k = 0; k < kPool; ++k)
            for (int i = 0; i < kPool; ++i) {
                const double wave = 0.6 * std::sin(kTau * (i / 16.0 - t / 60.0)) + 0.4 * std::sin(kTau * (k / 11.0 + t / 45.0));
                wobbled({double(i), j + wave * (j + 1) / kDepth, double(k)});  // deeper layers move less
            }
    // The drop: horizontal drift across the pool, vertical bounces between y = 16 and y = 28
    // (its lowest particles 4 spacings above the crests).
    const double phase = std::fmod(t, 100.0) / 50.0 - 1.0;  // -1 .. 1 over one arc
    const glm::dvec3 drop(8.0 + 0.12 * t, 16.0 + 12.0 * (1.0 - phase * phase), 10.0 + 0.09 * t);
    // It oscillates between prolate and oblate (volume kept): its tips and rim sharpen and
    // flatten, so their curvature sweeps through the level threshold.
    const double stretch = 1.3 + 0.7 * std::sin(kTau * t / 50.0);
    const glm::dvec3 axes(1.0 / std::sqrt(stretch), stretch, 1.0 / std::sqrt(stretch));
    for (const glm::dvec3& d : ball_offsets(8)) wobbled(drop + d * axes);
    // Droplets on a circle of radius 12 around the pool centre, at heights that rise and fall.
    for (int n = 0; n < 6; ++n) {
        const double angle = kTau * (n / 6.0 + t / 150.0);
        const glm::dvec3 c(19.5 + 12.0 * std::cos(angle), 15.0 + 2.0 * std::sin(kTau * t / 80.0 + n), 19.5 + 12.0 * std::sin(angle));
        const double wobble = 1.2 + 0.5 * std::sin(kTau * t / 37.0 + n);
        const glm::dvec3 shape(1.0 / std::sqrt(wobble), wobble, 1.0 / std::sqrt(wobble));
        for (const glm::dvec3& d : ball_offsets(4)) wobbled(c + d * shape);
    }
    return b.take();
}

/// Bodies with a known surface (analytic_bodies.hpp), for measuring meshes against it: the lattice
/// points jittered by up to a quarter spacing per axis (a rougher sampling than the other scenes',
/// as a simulation leaves it), kept where the jittered centre lies at least r inside the body, as
/// a fluid's particles fill it (each stands for a cube of side 2r around its centre; a ball of
/// radius 30r holds about 12,800). Keeping lattice points up to the surface instead would leave
/// the outer layer a whole spacing deep wherever a lattice plane just touches the surface (the
/// poles of a ball of a whole number of spacings), a terrace no reconstruction should follow.
/// Centred on the origin.
ParticleSet analytic_scene(SceneBuilder& b, const AnalyticBody& body) {
    constexpr double kBodyJitter = 0.25;
    const int n = int(std::ceil(std::max({body.a + body.b, body.b, body.c})));  // half-extent, lattice units
    for (int j = -n; j <= n; ++j)
        for (int k = -n; k <= n; ++k)
            for (int i = -n; i <= n; ++i)
                if (const glm::dvec3 p = b.jittered(i, j, k, kBodyJitter); body.signed_distance(p) <= -0.5) b.place(p.x, p.y, p.z);
    return b.take();
}

}  // namespace

std::vector<std::string> scene_names() {
    return {"block", "sphere", "dam-break", "pool-and-drop", "falling-drop", "ball", "torus", "rounded-box"};
}

namespace {
std::string known_scenes() {
    std::string known;
    for (const auto& n : scene_names()) known += (known.empty() ? "" : ", ") + n;
    return known;
}
}  // namespace

ParticleSet generate_scene(const std::string& name, float radius, std::uint64_t seed, int frame) {
    if (!std::isfinite(radius) || radius <= 0.0f)
        throw Error("scene '" + name + "': radius must be finite and > 0, got " + std::to_string(radius));
    if (frame < 0) throw Error("scene '" + name + "': frame must be >= 0, got " + std::to_string(frame));
    SceneBuilder b(radius, seed);
    ParticleSet set;
    if (name == "block") set = block(b);
    else if (name == "sphere") set = sphere(b);
    else if (name == "dam-break") set = dam_break(b);
    else if (name == "pool-and-drop") set = pool_and_drop(b);
    else if (name == "falling-drop") set = falling_drop(b, double(frame));
    else if (const auto body = analytic_body(name, 0.5)) set = analytic_scene(b, *body);  // lattice units: r = 1/2
    else throw Error("unknown scene '" + name + "', expected one of: " + known_scenes());
    for (float c : set.positions)
        if (!std::isfinite(c)) throw Error("scene '" + name + "': radius " + std::to_string(radius) + " is too large for float coordinates");
    return set;
}

}  // namespace trilevel
