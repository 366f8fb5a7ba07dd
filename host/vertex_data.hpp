// Per-vertex data of the output mesh, computed after triangulation (docs/design.md §2 stage 11): normals
// (Params::normals) and particle attributes interpolated at the vertices. Both run on the host
// over the finished mesh with the frame's one particle grid (core/particle_grid.hpp): the mesh is
// on the host already, and the cost is a few neighbour sums per vertex, small beside the pipeline
// (docs/operations.md, "Normals and attributes").
// Every vertex is computed on its own with sums in a fixed order, so the output is bit-identical
// for any thread count.
#pragma once

#include <cstddef>
#include <vector>

#include "core/field_at_point.hpp"
#include "core/particle_grid.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {

/// Step h of the central differences of the gradient normals, in particle radii.
constexpr double kGradientStep = 1e-3;

/// Search radius of the vertex stages, R + 2 h r in world units: it holds the neighbours of every
/// point within h of a vertex (each stage filters |x - x_j| < R). Also the cell edge of the
/// frame's particle grid, which keeps the neighbours' order of the stages' earlier grid.
float vertex_search_radius(float r, float R);

/// The particles binned for the vertex stages and the smoothing weights: cells of vertex_search_radius.
ParticleGrid vertex_particle_grid(const float* xyz, std::size_t count, float r, float R);

/// Area-weighted normals: per vertex the sum of the cross products (b - a) x (c - a) of its
/// triangles (twice their area times their unit normal), normalised. Outward for a mesh oriented
/// counter-clockwise from outside. Zero for a vertex whose triangles all have zero area.
std::vector<float> area_weighted_normals(const Mesh& mesh);

/// Field normals: n = grad phi / |grad phi| at each vertex, phi the Solenthaler field (docs/design.md
/// §3.3; inside the fluid phi < 0, so the gradient points outward), in double precision by
/// central differences (phi(v + h e_c) - phi(v - h e_c)) / 2h with h = kGradientStep * r. phi
/// has no practical closed-form gradient: its radius factor depends on the largest eigenvalue of
/// grad xbar. Where the gradient vanishes (no particle within R + h) the area-weighted normal
/// `fallback` of that vertex is used.
std::vector<float> gradient_normals(const Mesh& mesh, const ParticleGrid& grid, float r, float R,
                                    const std::vector<float>& fallback);

/// Error naming the first attribute that is not usable: components other than 1 or 3, a value
/// count other than components * count, a non-finite value, an empty, duplicate or white-space name.
void validate_attributes(const std::vector<ParticleAttribute>& attributes, std::size_t count);

/// Shepard-normalised SPH interpolation at each vertex v: A(v) = sum_j k_j A_j / sum_j k_j with
/// k_j = (1 - |v - x_j|^2 / R^2)^3 (the field's kernel) over the particles within R. Equal
/// particle masses make the m_j / rho_j factor of the SPH sum cancel against the normalisation,
/// so no density is needed and constants are reproduced exactly. A vertex without a particle
/// within R (the field is +R there, so a surface vertex has one) takes its nearest particle's
/// values. Accumulated in double, in the grid's particle order.
std::vector<VertexAttribute> interpolate_attributes(const Mesh& mesh, const ParticleGrid& grid,
                                                    const float* xyz, std::size_t count, float R,
                                                    const std::vector<ParticleAttribute>& attributes);

}  // namespace trilevel
