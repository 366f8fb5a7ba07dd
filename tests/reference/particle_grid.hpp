// The neighbour grid and the scalar field of the plain C++ references (tests/reference/): a hash
// grid written independently of the library's (src/core/particle_grid.hpp), so that the
// differential tests compare two implementations.
#pragma once

#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

namespace trilevel::reference {

/// Particles binned into a hash grid of cell size R: the neighbour search of every reference stage.
/// Within one cell particles keep ascending index order, so results are deterministic.
class ParticleGrid {
public:
    ParticleGrid(const std::vector<glm::vec3>& x, float R);

    /// Calls f(j, x_j, d2) for every particle j with |p - x_j|^2 = d2 < R^2 (d2 in double).
    template <class F>
    void for_each_neighbour(glm::vec3 p, F&& f) const {
        const glm::ivec3 c = cell_of(p);
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    auto it = ranges_.find(key(c + glm::ivec3(dx, dy, dz)));
                    if (it == ranges_.end()) continue;
                    for (std::uint32_t s = it->second.first; s < it->second.second; ++s) {
                        const glm::vec3 d = p - sorted_[s];
                        const double d2 = double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z;
                        if (d2 < R2_) f(order_[s], sorted_[s], d2);
                    }
                }
    }

    float radius() const { return R_; }

private:
    glm::ivec3 cell_of(glm::vec3 p) const;
    static std::uint64_t key(glm::ivec3 c);

    float R_;
    double R2_;
    glm::vec3 lo_;
    std::vector<int> order_;            ///< particle ids sorted by (cell key, id)
    std::vector<glm::vec3> sorted_;     ///< positions in that order
    std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>> ranges_;
};

// ---- Stage 6: the scalar field from a point's neighbours (docs/design.md §3.3) ------------------

/// Every intermediate of the scalar field at one point, for diagnostics and kernel comparisons.
struct FieldSample {
    double phi = 0.0;        ///< |x - xbar| - r f; +R when K == 0
    double K = 0.0;          ///< sum_j k_j
    glm::dvec3 xbar{0.0};    ///< weighted mean position
    double ev_max = 0.0;     ///< largest real eigenvalue part of J = grad xbar
    double f = 0.0;          ///< radius factor from ev_max
    int neighbours = 0;
};

/// f(EVmax): 1 below kEvLow, 0 above kEvHigh, gamma^3 - 3 gamma^2 + 3 gamma in between.
double radius_factor(double ev_max);

/// The field at x from the offsets y_j = x_j - x of its neighbours (|y_j| < R), summed in the
/// given order; xbar is returned relative to x. The normals (host/vertex_normals.cpp) call it at
/// points off the lattice with a faster eigenvalue method; the references with
/// reference::largest_real_eigenvalue (tests/reference/reference_stages.hpp).
FieldSample field_from_offsets(const glm::dvec3* y, std::size_t count, double r, double R,
                               double (*eigenvalue)(const double J[3][3]));

}  // namespace trilevel::reference
