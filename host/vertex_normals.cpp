// Stage 11a: per-vertex normals (host/vertex_data.hpp).
#include <algorithm>
#include <cmath>

#include <glm/glm.hpp>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "vertex_data.hpp"

namespace trilevel {

namespace {

glm::dvec3 vertex(const Mesh& m, std::size_t v) {
    return glm::dvec3(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]);
}

void store(std::vector<float>& out, std::size_t v, glm::dvec3 n) {
    for (int c = 0; c < 3; ++c) out[3 * v + c] = float(n[c]);
}

/// The particles within R + 2h of a vertex, as exact double offsets y_j = x_j - v.
struct Scratch {
    std::vector<glm::dvec3> near, shifted;
};

/// phi at v + d from the offsets of the particles around v: only those within R of v + d count.
double phi_at(const Scratch& s, std::vector<glm::dvec3>& shifted, glm::dvec3 d, double r, double R) {
    shifted.clear();
    for (const glm::dvec3& y : s.near) {
        const glm::dvec3 z = y - d;
        if (glm::dot(z, z) < R * R) shifted.push_back(z);
    }
    return field_from_offsets(shifted.data(), shifted.size(), r, R);
}

}  // namespace

float vertex_search_radius(float r, float R) { return float(R + 2.0 * kGradientStep * r); }

ParticleGrid vertex_particle_grid(const float* xyz, std::size_t count, float r, float R) {
    return ParticleGrid(xyz, count, vertex_search_radius(r, R));
}

std::vector<float> area_weighted_normals(const Mesh& mesh) {
    std::vector<glm::dvec3> sum(mesh.vertex_count(), glm::dvec3(0.0));
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {  // serial: a fixed summation order
        const std::uint32_t* tri = &mesh.triangles[3 * t];
        const glm::dvec3 a = vertex(mesh, tri[0]);
        const glm::dvec3 n = glm::cross(vertex(mesh, tri[1]) - a, vertex(mesh, tri[2]) - a);
        for (int k = 0; k < 3; ++k) sum[tri[k]] += n;
    }
    std::vector<float> out(3 * sum.size(), 0.0f);
    for (std::size_t v = 0; v < sum.size(); ++v) {
        const double len = glm::length(sum[v]);
        if (len > 0.0) store(out, v, sum[v] / len);
    }
    return out;
}

std::vector<float> gradient_normals(const Mesh& mesh, const ParticleGrid& grid, float r, float R,
                                    const std::vector<float>& fallback) {
    const double h = kGradientStep * r;
    const float reach = vertex_search_radius(r, R);
    const double reach2 = double(reach) * reach;
    std::vector<float> out(3 * mesh.vertex_count(), 0.0f);
    tbb::enumerable_thread_specific<Scratch> scratch;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.vertex_count(), 256), [&](const auto& range) {
        Scratch& s = scratch.local();
        for (std::size_t v = range.begin(); v < range.end(); ++v) {
            const glm::vec3 p(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
            s.near.clear();
            grid.for_each_candidate(p, reach, [&](std::uint32_t, glm::vec3 xj) {
                const glm::vec3 d = p - xj;  // the test in float differences, as the earlier grid made it
                if (double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z < reach2)
                    s.near.push_back(glm::dvec3(xj) - glm::dvec3(p));
            });
            glm::dvec3 g(0.0);
            for (int c = 0; c < 3; ++c) {
                glm::dvec3 d(0.0);
                d[c] = h;
                g[c] = (phi_at(s, s.shifted, d, r, R) - phi_at(s, s.shifted, -d, r, R)) / (2.0 * h);
            }
            const double len = glm::length(g);
            if (len > 1e-9 && std::isfinite(len)) store(out, v, g / len);
            else for (int c = 0; c < 3; ++c) out[3 * v + c] = fallback[3 * v + c];
        }
    });
    return out;
}

}  // namespace trilevel
