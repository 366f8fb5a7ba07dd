// Plain C++ reference implementations of the OpenCL stages 2, 3-4 and 6 (docs/design.md §2, §8).
// The differential tests compare every kernel against these functions on the same input.
// They follow docs/design.md §3 literally, accumulate in double and favour clarity over speed
// (a simple hash grid of cell R for the neighbour search, TBB over particles / points).
//
// Conventions shared with the kernels (all lengths in world units):
//   r = particle radius, R = support radius (= Params::kernel_radius * r), V = (2r)^3.
//   A neighbour of a point x is a particle j with |x - x_j| < R (a particle is not its own neighbour).
// Built into the tests' library (trilevel_testing, tests/CMakeLists.txt), never into trilevel.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "core/coarse_cells.hpp"
#include "reference/particle_grid.hpp"  // ParticleGrid, FieldSample, field_from_offsets

namespace trilevel::reference {

// ---- Stage 2: colour field, surface and splash particles (docs/design.md §3.1) -------------------------

/// Poly6 kernel W(d) = 315 / (64 pi R^9) (R^2 - d^2)^3 for d < R, from d^2.
double poly6(double d2, double R);
/// Poly6 gradient factor g with grad W(x_ij) = g * x_ij, g = -945 / (32 pi R^9) (R^2 - d^2)^2.
double poly6_gradient_factor(double d2, double R);

struct ParticleFlags {
    std::vector<float> color;          ///< c_i = sum_j V W(x_ij), the particle itself included
    std::vector<glm::vec3> gradient;   ///< n_i = sum_{j != i} V grad W(x_ij)
    std::vector<int> neighbours;       ///< neighbour count, the particle itself excluded
    std::vector<std::uint8_t> surface; ///< |n_i| R > kSurfaceGradient, or splash
    std::vector<std::uint8_t> splash;  ///< neighbours < kSplashNeighbours
    std::vector<std::uint8_t> thin;    ///< neighbours < kThinNeighbours, or not surface and neighbours below
                                       ///< sheet_neighbour_limit (a sheet one particle thick)
};

ParticleFlags color_field(const std::vector<glm::vec3>& x, float r, float R);

/// Outward unit normal -n / |n| (docs/design.md §3.1); the zero vector when n == 0.
glm::dvec3 outward_normal(glm::vec3 gradient);

// ---- Stage 4a: curvature per particle (paper eq. 1-2, docs/design.md §3.2) -----------------------------

/// kappa_i = sum over surface j != i with d < h = R of (1 - n_i . n_j)(1 - d / h) for surface
/// particles i (splash ones included, their normal may be zero); 0 for the others.
std::vector<float> curvature(const std::vector<glm::vec3>& x, const ParticleFlags& flags, float R);

// ---- Stages 3 + 4b: coarse surface cells, splash cells, levels (paper §3, §3.1, docs/design.md §3.2) ---

struct SurfaceCells {
    std::vector<CoarseCell> cells;      ///< sorted by lattice::pack(coord)
    std::vector<float> curvature;       ///< per cell: paper eq. 3 (or the 26-neighbour fallback),
                                        ///< averaged over the surface cells of the 3x3x3 block
    std::vector<std::uint8_t> splash;   ///< per cell: inside x_i +- R of a splash particle
    std::vector<std::uint8_t> thin_body;  ///< per cell (adaptive): no cell of its 3x3x3 block holds a
                                          ///< particle without a flag (surface, splash, thin)
};

/// Coarse cells of edge kCoarseCell * r, coord = floor((x - origin) * inv_edge), which must be >= 0,
/// inv_edge = 1.0f / (kCoarseCell * r), all in float exactly as the kernels compute it.
/// Surface cells: every cell overlapping the closed box x_i +- kSurfaceBoxHalf * r of a surface
/// (splash included) or thin particle i, i.e. per axis floor((x - origin - b) * inv_edge) ..
/// floor((x - origin + b) * inv_edge). A surface cell is a splash cell when it also overlaps
/// x_i +- kSplashBoxHalf*r of a splash or thin particle. Thin particles without surface gradient
/// (sheets) add the cells of their box too, as surface particles do. The level uses the cell curvature averaged over the 3x3x3 block.
/// forced_level: 0 = adaptive (level 3 if splash or curvature >= threshold, else 2); 2 or 3 =
/// uniform mode, every cell gets that level (and no cell is a thin body).
SurfaceCells surface_cells(const std::vector<glm::vec3>& x, const ParticleFlags& flags,
                           const std::vector<float>& kappa, glm::vec3 origin, float r, float R,
                           float threshold, int forced_level = 0);

// ---- Stage 6: scalar field (Solenthaler et al. 2007, docs/design.md §3.3) ------------------------------

/// Largest real part among the eigenvalues of a real 3x3 matrix (J need not be symmetric).
/// Method, independent of the kernel's closed-form cubic: Householder reduction to upper
/// Hessenberg form, then Francis double-shift QR steps until a subdiagonal entry vanishes; the
/// deflated 1x1 block and the 2x2 block's quadratic give the spectrum.
double largest_real_eigenvalue(const double J[3][3]);

FieldSample scalar_field_sample(glm::vec3 x, const ParticleGrid& grid, float r);
float scalar_field(glm::vec3 x, const ParticleGrid& grid, float r);
/// The field at every point (TBB over points); the grid is built with cell R.
std::vector<float> scalar_field(const std::vector<glm::vec3>& points, const std::vector<glm::vec3>& particles,
                                float r, float R);

}  // namespace trilevel::reference
