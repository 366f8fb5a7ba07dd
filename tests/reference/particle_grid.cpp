// The references' neighbour grid and scalar field; see particle_grid.hpp.
#include "reference/particle_grid.hpp"

#include <algorithm>
#include <stdexcept>

#include "stage_constants.hpp"

namespace trilevel::reference {

namespace {

constexpr int kOffset = 1 << 20;  // grid cell coordinates are stored with this offset, 21 bits per axis

}  // namespace

// ---- ParticleGrid ------------------------------------------------------------------------------

ParticleGrid::ParticleGrid(const std::vector<glm::vec3>& x, float R) : R_(R), R2_(double(R) * R), lo_(0.0f) {
    if (!(R > 0.0f)) throw std::invalid_argument("ParticleGrid: support radius must be > 0");
    if (!x.empty()) {
        lo_ = x[0];
        for (const glm::vec3& p : x) lo_ = glm::min(lo_, p);
    }
    std::vector<std::pair<std::uint64_t, int>> keyed(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) keyed[i] = {key(cell_of(x[i])), int(i)};
    std::sort(keyed.begin(), keyed.end());
    order_.resize(x.size());
    sorted_.resize(x.size());
    for (std::size_t s = 0; s < keyed.size(); ++s) {
        order_[s] = keyed[s].second;
        sorted_[s] = x[std::size_t(keyed[s].second)];
        auto [it, fresh] = ranges_.try_emplace(keyed[s].first, std::uint32_t(s), std::uint32_t(s + 1));
        if (!fresh) it->second.second = std::uint32_t(s + 1);
    }
}

glm::ivec3 ParticleGrid::cell_of(glm::vec3 p) const {
    const glm::vec3 c = glm::floor((p - lo_) / R_);
    // Far-away query points clamp onto an unused border coordinate: they find no particles.
    return glm::ivec3(glm::clamp(c, glm::vec3(-float(kOffset) + 2), glm::vec3(float(kOffset) - 2)));
}

std::uint64_t ParticleGrid::key(glm::ivec3 c) {
    const glm::uvec3 u = glm::uvec3(c + kOffset);
    return std::uint64_t(u.x) | (std::uint64_t(u.y) << 21) | (std::uint64_t(u.z) << 42);
}

// ---- Stage 6: scalar field ---------------------------------------------------------------------

double radius_factor(double ev_max) {
    if (ev_max < constants::kEvLow) return 1.0;
    if (ev_max > constants::kEvHigh) return 0.0;
    const double g = (constants::kEvHigh - ev_max) / (double(constants::kEvHigh) - constants::kEvLow);
    return g * g * g - 3.0 * g * g + 3.0 * g;
}

FieldSample field_from_offsets(const glm::dvec3* y, std::size_t count, double r, double R,
                               double (*eigenvalue)(const double J[3][3])) {
    // Sums over y_j = x_j - x (small numbers, no cancellation against large coordinates):
    // K, sum k_j y_j, sum grad k_j, sum y_j (x) grad k_j.
    FieldSample s;
    glm::dvec3 ky(0.0), gk(0.0);
    glm::dmat3 ygk(0.0);  // column-major: ygk[b][a] = sum y_a (grad k)_b
    for (std::size_t j = 0; j < count; ++j) {
        const double u = 1.0 - glm::dot(y[j], y[j]) / (R * R);
        if (u <= double(constants::kSupportCut)) continue;  // the support's cut rim (stage_constants.hpp)
        const double k = u * u * u;
        const glm::dvec3 grad = 6.0 * u * u * y[j] / (R * R);  // grad k_j = -6 (1 - s^2)^2 (x - x_j) / R^2
        s.K += k;
        ky += k * y[j];
        gk += grad;
        ygk += glm::outerProduct(y[j], grad);
    }
    s.neighbours = int(count);
    if (s.K <= 0.0) {
        s.phi = R;
        return s;
    }
    const glm::dvec3 ybar = ky / s.K;
    // J[a][b] = sum_j (x_j - xbar)_a (grad k_j)_b / K = (sum y_a g_b - ybar_a sum g_b) / K.
    const glm::dmat3 Jm = (ygk - glm::outerProduct(ybar, gk)) / s.K;
    double J[3][3];
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) J[a][b] = Jm[b][a];
    s.xbar = ybar;
    s.ev_max = eigenvalue(J);
    s.f = radius_factor(s.ev_max);
    s.phi = glm::length(ybar) - r * s.f;
    return s;
}

}  // namespace trilevel::reference
