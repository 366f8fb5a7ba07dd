// A toy simulator that meshes its fluid every step with trilevel, straight from its own particle
// array (no files): a drop falls towards a pool. One Reconstructor is created up front and reused,
// so the OpenCL kernels are compiled once and device buffers are recycled between steps.
//
// Exits non-zero when a step's mesh is empty, not closed, or does not follow the drop.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <random>
#include <string>
#include <vector>

#include <trilevel/trilevel.hpp>

namespace {

constexpr float kRadius = 0.025f;           // particle radius r, world units
constexpr float kSpacing = 2.0f * kRadius;  // rest spacing of the particles

struct Fluid {
    std::vector<float> xyz;        // x, y, z per particle: what the simulator integrates
    std::vector<float> vy;         // vertical velocity per particle (y is up)
    std::vector<bool> in_drop;     // the drop moves, the pool rests
};

/// A pool of 24 x 4 x 24 particles and a ball of radius 5 spacings above it, slightly jittered.
Fluid make_scene() {
    Fluid f;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> jitter(-0.05f * kSpacing, 0.05f * kSpacing);
    auto add = [&](float x, float y, float z, bool drop) {
        f.xyz.insert(f.xyz.end(), {x + jitter(rng), y + jitter(rng), z + jitter(rng)});
        f.vy.push_back(0.0f);
        f.in_drop.push_back(drop);
    };
    for (int i = 0; i < 24; ++i)
        for (int j = 0; j < 24; ++j)
            for (int k = 0; k < 4; ++k) add(i * kSpacing, k * kSpacing, j * kSpacing, false);
    const float cx = 11.5f * kSpacing, cy = 20.0f * kSpacing, cz = 11.5f * kSpacing;
    for (int i = -5; i <= 5; ++i)
        for (int j = -5; j <= 5; ++j)
            for (int k = -5; k <= 5; ++k)
                if (i * i + j * j + k * k <= 25) add(cx + i * kSpacing, cy + j * kSpacing, cz + k * kSpacing, true);
    return f;
}

/// One explicit Euler step of free fall for the drop particles.
void step(Fluid& f, float dt) {
    for (std::size_t i = 0; i < f.vy.size(); ++i) {
        if (!f.in_drop[i]) continue;
        f.vy[i] -= 9.81f * dt;
        f.xyz[3 * i + 1] += f.vy[i] * dt;
    }
}

/// The largest y of x, y, z triplets.
float top(const std::vector<float>& xyz) {
    float y = xyz[1];
    for (std::size_t i = 1; i < xyz.size(); i += 3) y = std::max(y, xyz[i]);
    return y;
}

}  // namespace

int main() {
    try {
        Fluid fluid = make_scene();
        trilevel::Reconstructor rec;  // device chosen once: TRILEVEL_DEVICE, else first GPU, else CPU
        trilevel::Params params;
        params.particle_radius = kRadius;  // every other length parameter keeps its default (in r)
        std::printf("device: %s, %zu particles\n", rec.device().name.c_str(), fluid.vy.size());

        bool ok = true;
        for (int s = 0; s < 5; ++s) {
            trilevel::Stats stats;
            const trilevel::Mesh mesh = rec.reconstruct(fluid.xyz.data(), fluid.vy.size(), params, &stats);
            if (mesh.triangle_count() == 0) throw trilevel::Error("step " + std::to_string(s) + ": empty mesh");
            // The mesh must move with the drop: its top stays within one radius of the topmost particle.
            const float lift = top(mesh.positions) - top(fluid.xyz);
            const bool tracks = std::abs(lift) < kRadius;
            std::printf("step %d: %zu vertices, %zu triangles (level 3: %zu), closed: %s, top - drop top: %.2f r\n", s,
                        mesh.vertex_count(), mesh.triangle_count(), stats.triangles_level3,
                        stats.closed ? "yes" : "no", lift / kRadius);
            ok = ok && trilevel::is_closed_and_oriented(mesh) && tracks;
            step(fluid, 0.04f);
        }
        return ok ? 0 : 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "simulator_loop: error: %s\n", e.what());
        return 1;
    }
}
