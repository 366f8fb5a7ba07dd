// Stage 11b: particle attributes interpolated at the mesh vertices (host/vertex_data.hpp).
#include <cctype>
#include <cmath>
#include <set>

#include <glm/glm.hpp>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "vertex_data.hpp"

namespace trilevel {

namespace {

/// Kernel weights of the particles around one vertex, in grid order.
struct Weights {
    std::vector<std::pair<std::uint32_t, double>> w;
    double sum = 0.0;
};

/// The particle nearest to p (lowest index on ties); only for vertices with no particle within R.
int nearest_particle(const float* xyz, std::size_t count, glm::vec3 p) {
    int best = 0;
    double best_d2 = INFINITY;
    for (std::size_t j = 0; j < count; ++j) {
        const glm::dvec3 d = glm::dvec3(xyz[3 * j], xyz[3 * j + 1], xyz[3 * j + 2]) - glm::dvec3(p);
        const double d2 = glm::dot(d, d);
        if (d2 < best_d2) best_d2 = d2, best = int(j);
    }
    return best;
}

}  // namespace

void validate_attributes(const std::vector<ParticleAttribute>& attributes, std::size_t count) {
    std::set<std::string> seen;
    for (const ParticleAttribute& a : attributes) {
        const std::string what = "particle attribute '" + a.name + "'";
        if (a.name.empty()) throw Error("a particle attribute has an empty name");
        for (char ch : a.name)
            if (std::isspace(static_cast<unsigned char>(ch)) || std::iscntrl(static_cast<unsigned char>(ch)))
                throw Error(what + ": names cannot hold white space or control characters");
        if (!seen.insert(a.name).second) throw Error(what + " is given twice");
        if (a.components != 1 && a.components != 3)
            throw Error(what + " has " + std::to_string(a.components) + " components, expected 1 or 3");
        if (a.values.size() != std::size_t(a.components) * count)
            throw Error(what + " has " + std::to_string(a.values.size()) + " values for " + std::to_string(count) +
                        " particles of " + std::to_string(a.components) + " components");
        for (std::size_t i = 0; i < a.values.size(); ++i)
            if (!std::isfinite(a.values[i]))
                throw Error(what + ": particle " + std::to_string(i / std::size_t(a.components)) + " has a non-finite value");
    }
}

std::vector<VertexAttribute> interpolate_attributes(const Mesh& mesh, const ParticleGrid& grid,
                                                    const float* xyz, std::size_t count, float R,
                                                    const std::vector<ParticleAttribute>& attributes) {
    const std::size_t nv = mesh.vertex_count();
    std::vector<VertexAttribute> out;
    for (const ParticleAttribute& a : attributes) out.push_back({a.name, a.components, std::vector<float>(a.components * nv)});
    const double R2 = double(R) * R;
    tbb::enumerable_thread_specific<Weights> scratch;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 256), [&](const auto& range) {
        Weights& w = scratch.local();
        for (std::size_t v = range.begin(); v < range.end(); ++v) {
            const glm::vec3 p(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
            w.w.clear();
            w.sum = 0.0;
            grid.for_each_candidate(p, R, [&](std::uint32_t j, glm::vec3 xj) {
                const glm::vec3 d = p - xj;
                const double d2 = double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z;
                if (d2 >= R2) return;
                const double u = 1.0 - d2 / R2;
                w.w.emplace_back(j, u * u * u);
                w.sum += u * u * u;
            });
            if (!(w.sum > 0.0)) {
                w.w.assign(1, {std::uint32_t(nearest_particle(xyz, count, p)), 1.0});
                w.sum = 1.0;
            }
            for (std::size_t a = 0; a < attributes.size(); ++a) {
                const int nc = attributes[a].components;
                const float* values = attributes[a].values.data();
                for (int c = 0; c < nc; ++c) {
                    double acc = 0.0;
                    for (const auto& [j, k] : w.w) acc += k * values[std::size_t(j) * nc + c];
                    out[a].values[v * nc + c] = float(acc / w.sum);
                }
            }
        }
    });
    return out;
}

}  // namespace trilevel
