// The scalar field at one point; see field_at_point.hpp.
#include "core/field_at_point.hpp"

#include <algorithm>
#include <cmath>

#include "stage_constants.hpp"

namespace trilevel {

double largest_real_eigenvalue_cubic(const double J[3][3]) {
    // Characteristic polynomial l^3 - t l^2 + m l - d; l = u + t/3 gives u^3 + p u + q = 0.
    const glm::dvec3 a(J[0][0], J[0][1], J[0][2]), b(J[1][0], J[1][1], J[1][2]), c(J[2][0], J[2][1], J[2][2]);
    const double t = a.x + b.y + c.z;
    const double m = (a.x * b.y - a.y * b.x) + (a.x * c.z - a.z * c.x) + (b.y * c.z - b.z * c.y);
    const double d = glm::dot(a, glm::cross(b, c));
    const double s = t / 3.0, p = m - t * s, q = -d + m * s - 2.0 * s * s * s;
    const double disc = 0.25 * q * q + p * p * p / 27.0;
    if (disc <= 0.0 && p < 0.0) {  // three real roots: trigonometric method, the largest
        const double rho = std::sqrt(-p / 3.0);
        const double arg = std::clamp(-q / (2.0 * rho * rho * rho), -1.0, 1.0);
        return 2.0 * rho * std::cos(std::acos(arg) / 3.0) + s;
    }
    // one real root u1 and a complex pair of real part -u1/2
    const double sq = std::sqrt(std::max(disc, 0.0));
    const double u1 = std::cbrt(-0.5 * q + sq) + std::cbrt(-0.5 * q - sq);
    return std::max(u1, -0.5 * u1) + s;
}

namespace {

/// f(EVmax): 1 below kEvLow, 0 above kEvHigh, gamma^3 - 3 gamma^2 + 3 gamma in between.
double radius_factor(double ev_max) {
    if (ev_max < constants::kEvLow) return 1.0;
    if (ev_max > constants::kEvHigh) return 0.0;
    const double g = (constants::kEvHigh - ev_max) / (double(constants::kEvHigh) - constants::kEvLow);
    return g * g * g - 3.0 * g * g + 3.0 * g;
}

}  // namespace

double field_from_offsets(const glm::dvec3* y, std::size_t count, double r, double R) {
    // Sums over y_j = x_j - x (small numbers, no cancellation against large coordinates):
    // K, sum k_j y_j, sum grad k_j, sum y_j (x) grad k_j.
    double K = 0.0;
    glm::dvec3 ky(0.0), gk(0.0);
    glm::dmat3 ygk(0.0);  // column-major: ygk[b][a] = sum y_a (grad k)_b
    for (std::size_t j = 0; j < count; ++j) {
        const double u = 1.0 - glm::dot(y[j], y[j]) / (R * R);
        if (u <= double(constants::kSupportCut)) continue;  // the support's cut rim (stage_constants.hpp)
        const double k = u * u * u;
        const glm::dvec3 grad = 6.0 * u * u * y[j] / (R * R);  // grad k_j = -6 (1 - s^2)^2 (x - x_j) / R^2
        K += k;
        ky += k * y[j];
        gk += grad;
        ygk += glm::outerProduct(y[j], grad);
    }
    if (K <= 0.0) return R;
    const glm::dvec3 ybar = ky / K;
    // J[a][b] = sum_j (x_j - xbar)_a (grad k_j)_b / K = (sum y_a g_b - ybar_a sum g_b) / K.
    const glm::dmat3 Jm = (ygk - glm::outerProduct(ybar, gk)) / K;
    double J[3][3];
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) J[a][b] = Jm[b][a];
    return glm::length(ybar) - r * radius_factor(largest_real_eigenvalue_cubic(J));
}

}  // namespace trilevel
