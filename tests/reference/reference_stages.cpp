// Reference implementations of the device stages (docs/design.md §2, §3, §8); see reference_stages.hpp.
#include "reference/reference_stages.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <unordered_set>

#include <tbb/parallel_for.h>

#include "core/lattice.hpp"
#include "stage_constants.hpp"

namespace trilevel::reference {

namespace {

template <class F>
void parallel_over(std::size_t n, F&& f) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const tbb::blocked_range<std::size_t>& b) {
        for (std::size_t i = b.begin(); i < b.end(); ++i) f(i);
    });
}

}  // namespace

// ---- Stage 2 -----------------------------------------------------------------------------------

double poly6(double d2, double R) {
    if (d2 >= R * R) return 0.0;
    const double t = R * R - d2;
    return 315.0 / (64.0 * std::numbers::pi * std::pow(R, 9)) * t * t * t;
}

double poly6_gradient_factor(double d2, double R) {
    if (d2 >= R * R) return 0.0;
    const double t = R * R - d2;
    return -945.0 / (32.0 * std::numbers::pi * std::pow(R, 9)) * t * t;
}

glm::dvec3 outward_normal(glm::vec3 gradient) {
    const glm::dvec3 n(gradient);
    const double len = glm::length(n);
    return len > 0.0 ? -n / len : glm::dvec3(0.0);
}

ParticleFlags color_field(const std::vector<glm::vec3>& x, float r, float R) {
    const std::size_t n = x.size();
    const double V = std::pow(2.0 * r, 3);
    const ParticleGrid grid(x, R);
    ParticleFlags out;
    out.color.resize(n);
    out.gradient.resize(n);
    out.neighbours.resize(n);
    out.surface.resize(n);
    out.splash.resize(n);
    out.thin.resize(n);
    const float sheet_limit = constants::sheet_neighbour_limit(R, std::pow(2.0f * r, 3.0f));  // as color_field gets it
    parallel_over(n, [&](std::size_t i) {
        double c = poly6(0.0, R);  // the particle itself
        glm::dvec3 g(0.0);
        int count = 0;
        double closeness = double(R) * R;  // the particle itself
        grid.for_each_neighbour(x[i], [&](int j, glm::vec3 xj, double d2) {
            if (std::size_t(j) == i) return;
            if (d2 > double(constants::kSameSpot) * constants::kSameSpot * R * R) ++count;  // else the same spot
            closeness += double(R) * R - d2;
            c += poly6(d2, R);
            g += poly6_gradient_factor(d2, R) * glm::dvec3(x[i] - xj);
        });
        out.color[i] = float(V * c);
        out.gradient[i] = glm::vec3(V * g);
        out.neighbours[i] = count;
        const double pile = (count + 1) * (1.0 - double(constants::kPileFraction) * constants::kPileFraction) * R * R;
        out.splash[i] = count < constants::kSplashNeighbours || closeness >= pile;  // few neighbours, or a pile
        out.surface[i] = out.splash[i] || V * glm::length(g) * R > constants::kSurfaceGradient;
        out.thin[i] = count < constants::kThinNeighbours || (!out.surface[i] && float(count) < sheet_limit);
    });
    return out;
}

// ---- Stage 4a ----------------------------------------------------------------------------------

std::vector<float> curvature(const std::vector<glm::vec3>& x, const ParticleFlags& flags, float R) {
    const std::size_t n = x.size();
    std::vector<glm::dvec3> normal(n);
    for (std::size_t i = 0; i < n; ++i) normal[i] = outward_normal(flags.gradient[i]);
    const ParticleGrid grid(x, R);
    std::vector<float> kappa(n, 0.0f);
    parallel_over(n, [&](std::size_t i) {
        if (!flags.surface[i]) return;
        double k = 0.0;
        grid.for_each_neighbour(x[i], [&](int j, glm::vec3, double d2) {
            if (std::size_t(j) == i || !flags.surface[std::size_t(j)]) return;
            k += (1.0 - glm::dot(normal[i], normal[std::size_t(j)])) * (1.0 - std::sqrt(d2) / R);  // eq. 1-2
        });
        kappa[i] = float(std::max(k, 0.0));  // >= 0 by definition; parallel normals round either way
    });
    return kappa;
}

// ---- Stages 3 + 4b -----------------------------------------------------------------------------

namespace {

struct CellBox {
    glm::ivec3 lo, hi;
};

/// Coarse cell of the point q (relative to the grid origin). Written as the kernels write it,
/// floor(q * (1 / edge)) in float, so that boxes ending exactly on a cell face round alike.
glm::ivec3 coarse_of(glm::vec3 q, float inv_edge) { return glm::ivec3(glm::floor(q * inv_edge)); }

/// Coarse cells overlapping the closed box p +- b (paper §3: AABB around a particle).
CellBox cells_overlapping(glm::vec3 p, glm::vec3 origin, float b, float inv_edge) {
    const glm::vec3 q = p - origin;
    const CellBox box{coarse_of(q - b, inv_edge), coarse_of(q + b, inv_edge)};
    if (glm::any(glm::lessThan(box.lo, glm::ivec3(0))) || glm::any(glm::greaterThan(box.hi, glm::ivec3(lattice::kMaxCoord))))
        throw std::invalid_argument("surface_cells: a particle box leaves the coarse grid (origin too high?)");
    return box;
}

template <class F>
void for_each_cell(const CellBox& b, F&& f) {
    for (int z = b.lo.z; z <= b.hi.z; ++z)
        for (int y = b.lo.y; y <= b.hi.y; ++y)
            for (int x = b.lo.x; x <= b.hi.x; ++x) f(lattice::pack(x, y, z));
}

struct CellKappa {
    double sum = 0.0;
    int count = 0;
    float max = 0.0f;
};

/// Calls f(value) for every entry of `map` keyed by a cell of the 3x3x3 block around `c`, in z, y, x
/// order (the order of FOR_EACH_CELL_IN_BLOCK in kernels/curvature.cl).
template <class Map, class F>
void for_each_in_block(glm::ivec3 c, const Map& map, F&& f) {
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                const glm::ivec3 q = c + glm::ivec3(dx, dy, dz);
                if (!lattice::in_range(q)) continue;
                if (auto it = map.find(lattice::pack(q)); it != map.end()) f(it->second);
            }
}

/// Eq. 3 per cell holding surface particles; the largest kappa of the 26 neighbours otherwise.
float cell_curvature(glm::ivec3 c, const std::unordered_map<std::uint64_t, CellKappa>& per_cell) {
    if (auto it = per_cell.find(lattice::pack(c)); it != per_cell.end()) return float(it->second.sum / it->second.count);
    float best = 0.0f;
    for_each_in_block(c, per_cell, [&](const CellKappa& k) { best = std::max(best, k.max); });
    return best;
}

}  // namespace

SurfaceCells surface_cells(const std::vector<glm::vec3>& x, const ParticleFlags& flags, const std::vector<float>& kappa,
                           glm::vec3 origin, float r, float /*R*/, float threshold, int forced_level) {
    const float inv_edge = 1.0f / (constants::kCoarseCell * r);
    std::vector<std::uint64_t> keys;
    std::unordered_set<std::uint64_t> splash_keys;
    std::unordered_map<std::uint64_t, CellKappa> per_cell;
    std::unordered_set<std::uint64_t> interior;  // cells holding a particle without a flag
    for (std::size_t i = 0; i < x.size(); ++i) {
        if (!flags.surface[i] && !flags.splash[i] && !flags.thin[i])
            interior.insert(lattice::pack(coarse_of(x[i] - origin, inv_edge)));
        if (!flags.surface[i] && !flags.thin[i]) continue;
        for_each_cell(cells_overlapping(x[i], origin, constants::kSurfaceBoxHalf * r, inv_edge),
                      [&](std::uint64_t k) { keys.push_back(k); });
        if (flags.splash[i] || flags.thin[i])
            for_each_cell(cells_overlapping(x[i], origin, constants::kSplashBoxHalf * r, inv_edge),
                          [&](std::uint64_t k) { splash_keys.insert(k); });
        if (!flags.surface[i]) continue;  // a sheet particle: no normal, no curvature
        CellKappa& ck = per_cell[lattice::pack(coarse_of(x[i] - origin, inv_edge))];
        ck.sum += kappa[i];
        ck.count += 1;
        ck.max = std::max(ck.max, kappa[i]);
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());

    SurfaceCells out;
    out.cells.resize(keys.size());
    out.curvature.resize(keys.size());
    out.splash.resize(keys.size());
    out.thin_body.resize(keys.size());
    std::unordered_map<std::uint64_t, float> smoothed;  // eq. 3 (or the neighbour fallback) per cell
    for (std::uint64_t k : keys) smoothed[k] = cell_curvature(lattice::unpack(k), per_cell);
    // Means over the surface cells of the 3x3x3 block (kernels/curvature.cl, smooth_cell_curvature).
    for (int pass = 0; pass < constants::kCurvatureSmoothingPasses; ++pass) {
        std::unordered_map<std::uint64_t, float> next;
        for (std::uint64_t k : keys) {
            double sum = 0.0;
            int n = 0;
            for_each_in_block(lattice::unpack(k), smoothed, [&](float v) { sum += v, ++n; });
            next[k] = float(sum / n);
        }
        smoothed.swap(next);
    }
    for (std::size_t c = 0; c < keys.size(); ++c) {
        const glm::ivec3 coord = lattice::unpack(keys[c]);
        out.curvature[c] = smoothed[keys[c]];
        out.splash[c] = splash_keys.count(keys[c]) != 0;
        bool inside = false;  // a surface cell of the 3x3x3 block holds an interior particle
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const glm::ivec3 q = coord + glm::ivec3(dx, dy, dz);
                    if (glm::all(glm::greaterThanEqual(q, glm::ivec3(0))) &&
                        std::binary_search(keys.begin(), keys.end(), lattice::pack(q)) && interior.count(lattice::pack(q)))
                        inside = true;
                }
        out.thin_body[c] = forced_level == 0 && !inside;
        const bool fine = out.splash[c] || out.curvature[c] >= threshold;
        out.cells[c].coord = coord;
        out.cells[c].level = std::uint8_t(forced_level == 2 || forced_level == 3 ? forced_level : (fine ? 3 : 2));
    }
    return out;
}

// ---- Stage 6: eigenvalues ----------------------------------------------------------------------

namespace {

using Mat3 = double[3][3];

/// H <- P H P with the Householder reflector P = I - 2 v v^T / v^T v acting on indices k..k+m-1.
void reflect(Mat3& H, const double* v, int k, int m) {
    double vv = 0.0;
    for (int i = 0; i < m; ++i) vv += v[i] * v[i];
    if (vv == 0.0) return;
    for (int c = 0; c < 3; ++c) {  // from the left: rows k..k+m-1
        double w = 0.0;
        for (int i = 0; i < m; ++i) w += v[i] * H[k + i][c];
        for (int i = 0; i < m; ++i) H[k + i][c] -= 2.0 * v[i] * w / vv;
    }
    for (int row = 0; row < 3; ++row) {  // from the right: columns k..k+m-1
        double w = 0.0;
        for (int i = 0; i < m; ++i) w += H[row][k + i] * v[i];
        for (int i = 0; i < m; ++i) H[row][k + i] -= 2.0 * w * v[i] / vv;
    }
}

/// Householder vector mapping a (length m) onto a multiple of e_0.
void householder(const double* a, int m, double* v) {
    double norm = 0.0;
    for (int i = 0; i < m; ++i) norm += a[i] * a[i];
    norm = std::sqrt(norm);
    for (int i = 0; i < m; ++i) v[i] = a[i];
    v[0] += a[0] >= 0.0 ? norm : -norm;
}

/// Largest real part of the eigenvalues of [[a, b], [c, d]].
double max_real_2x2(double a, double b, double c, double d) {
    const double p = 0.5 * (a + d), q = 0.5 * (a - d);
    const double disc = q * q + b * c;
    return disc >= 0.0 ? p + std::sqrt(disc) : p;
}

bool negligible(double sub, double diag_a, double diag_b, double norm) {
    const double scale = std::abs(diag_a) + std::abs(diag_b);
    return std::abs(sub) <= 4.0 * DBL_EPSILON * (scale > 0.0 ? scale : norm);
}

/// One Francis double-shift QR step on the 3x3 Hessenberg H (shifts: eigenvalues of the
/// trailing 2x2 block, or an exceptional shift to break cycles), then the bulge chase.
void francis_step(Mat3& H, int iteration) {
    double s = H[1][1] + H[2][2], t = H[1][1] * H[2][2] - H[1][2] * H[2][1];
    if (iteration % 11 == 10) {  // exceptional shift
        const double w = H[2][2] + std::abs(H[2][1]) + std::abs(H[1][0]);
        s = 2.0 * w;
        t = w * w;
    }
    const double first[3] = {H[0][0] * H[0][0] + H[0][1] * H[1][0] - s * H[0][0] + t,
                             H[1][0] * (H[0][0] + H[1][1] - s), H[1][0] * H[2][1]};
    double v[3];
    householder(first, 3, v);
    reflect(H, v, 0, 3);
    const double bulge[2] = {H[1][0], H[2][0]};
    householder(bulge, 2, v);
    reflect(H, v, 1, 2);
    H[2][0] = 0.0;
}

}  // namespace

double largest_real_eigenvalue(const double J[3][3]) {
    Mat3 H;
    double norm = 0.0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) norm = std::max(norm, std::abs(H[i][j] = J[i][j]));
    if (norm == 0.0) return 0.0;
    const double col[2] = {H[1][0], H[2][0]};  // reduce to upper Hessenberg form
    double v[2];
    householder(col, 2, v);
    reflect(H, v, 1, 2);
    H[2][0] = 0.0;
    for (int it = 0; it < 200; ++it) {
        if (negligible(H[2][1], H[1][1], H[2][2], norm))
            return std::max(H[2][2], max_real_2x2(H[0][0], H[0][1], H[1][0], H[1][1]));
        if (negligible(H[1][0], H[0][0], H[1][1], norm))
            return std::max(H[0][0], max_real_2x2(H[1][1], H[1][2], H[2][1], H[2][2]));
        francis_step(H, it);
    }
    // Not converged (never seen): the best estimate from the current quasi-triangular form.
    return std::max(H[2][2], max_real_2x2(H[0][0], H[0][1], H[1][0], H[1][1]));
}

// ---- Stage 6: scalar field ---------------------------------------------------------------------

FieldSample scalar_field_sample(glm::vec3 x, const ParticleGrid& grid, float r) {
    thread_local std::vector<glm::dvec3> y;
    y.clear();
    grid.for_each_neighbour(x, [&](int, glm::vec3 xj, double) { y.emplace_back(xj - x); });
    FieldSample s = field_from_offsets(y.data(), y.size(), r, grid.radius(), largest_real_eigenvalue);
    s.xbar += glm::dvec3(x);
    return s;
}

float scalar_field(glm::vec3 x, const ParticleGrid& grid, float r) { return float(scalar_field_sample(x, grid, r).phi); }

std::vector<float> scalar_field(const std::vector<glm::vec3>& points, const std::vector<glm::vec3>& particles, float r,
                                float R) {
    const ParticleGrid grid(particles, R);
    std::vector<float> phi(points.size());
    parallel_over(points.size(), [&](std::size_t i) { phi[i] = scalar_field(points[i], grid, r); });
    return phi;
}

}  // namespace trilevel::reference
