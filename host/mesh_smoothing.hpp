// Smoothing of a reconstructed mesh (Params::smooth): weighted Laplacian smoothing in the manner
// of Löschner, Böttcher, Jeske and Bender, "Weighted Laplacian Smoothing for Surface
// Reconstruction of Particle-based Fluids" (VMV 2023): each vertex moves towards the mean of its
// neighbours by a weight taken from the particles around it, so that surfaces of splash and thin
// particles (few neighbours) barely move while the bumps of the bulk's particles are ironed out.
// The curvature-following shrink of the Laplacian steps is given back along the normals (its
// wide-neighbourhood average); the vertices then follow the vertex normals averaged over that
// wide neighbourhood, which flattens the long bumps the Laplacian steps leave without shrinking;
// a final correction along the normals restores each connected component's volume exactly (to
// rounding). Only positions change, never the index topology, so
// a closed oriented mesh stays closed and oriented; a step that would turn a triangle over
// (against its orientation before smoothing) is taken back at that triangle's corners.
// Every vertex is computed on its own over a fixed adjacency, and per-component sums run in
// triangle order: the same bits at any thread count.
#pragma once

#include <cstddef>
#include <vector>

#include "core/particle_grid.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {

/// Weight of each vertex in [0, 1] from the particles around it: with the kernel sum
/// c(v) = sum_j (1 - |v - x_j|^2 / R^2)^3 over the particles within R (the field's kernel; a
/// weighted count of the particles the vertex sees) and c_flat its value on the flat surface of
/// particles at rest spacing 2r, w(v) = smoothstep((c(v) / c_flat - 0.45) / 0.35) (clamped to
/// [0, 1]). Vertices of a lone splash particle (c about 0.8 against c_flat about 3.7 at R = 4r)
/// get 0 and stay put, those of thin jets and sheets a small weight; the bulk's surface gets 1. Löschner et al. weight by the particles' neighbour
/// counts, which needs a second neighbour search per particle: measured on the x64 dam break,
/// that search cost as much as the reconstruction's scalar field, while this one is one search
/// per vertex. A vertex without particles within R gets 0. `positions`: the vertices as x, y, z
/// (Mesh::positions; the weights read nothing else of the mesh). `grid`: the frame's particles
/// (any cell edge; the reconstruction shares the vertex stages' grid), world units.
std::vector<float> smoothing_weights(const std::vector<float>& positions, const ParticleGrid& grid, float r, float R);

struct SmoothingSettings {
    int iterations = 0;        ///< Laplacian steps (with mu != 0: lambda/mu pairs); 0: no smoothing
    /// Step towards the neighbours' mean, times the vertex weight. 1 (to the mean): as smooth as
    /// 0.5 with twice the steps at half the cost (measured on the analytic bodies).
    double lambda = 1.0;
    /// Taubin's inflating step after each lambda step; 0: none. Measured on the jittered analytic
    /// bodies (bench/RESULTS-smoothing.md) Taubin pairs leave the particle bumps, whose wavelength
    /// of a few edges lies in Taubin's pass band, and amplify them for |mu| > 0.55: off by default.
    double mu = 0.0;
    /// Rounds of 1-ring averaging that estimate the curvature shrink given back at the end (see
    /// mesh_smoothing.cpp); 0: none.
    int shrink_passes = 10;
    /// Rounds of 1-ring averaging of the vertex normals that the vertices then follow in
    /// update_passes moves (see mesh_smoothing.cpp); either 0: none. This removes the bumps several
    /// particle spacings wide that the Laplacian steps leave, without shrinking the body
    /// (bench/RESULTS-smoothing.md).
    int normal_passes = 20;
    int update_passes = 9;  ///< moves of the vertices towards the averaged normals
    /// Over-relaxation of those moves: each goes this many times the way to the mean of the
    /// projections. Measured on the analytic bodies and the dam-break frames, 9 moves at 1.7 end
    /// as close as 15 at 1 (bench/RESULTS-smoothing.md); the guard takes back any that would
    /// turn a triangle over.
    double update_step = 1.7;
    int tangential_passes = 1;  ///< tangential Laplacian steps after the update (triangle shapes)
    bool keep_volume = true;   ///< restore each component's volume along the normals at the end
    /// Components enclosing less than this volume (world units) are left as they are: a droplet of
    /// a few particles has no particle bumps to iron out, and Laplacian steps would shrink it to
    /// a sliver that the volume correction cannot regrow. smooth_min_volume(r) is the default's.
    double min_volume = 0.0;
};

/// Components under 64 particle volumes, 64 (2r)^3 (a droplet of radius about 5r), stay as they are.
inline double smooth_min_volume(double r) { return 64.0 * 8.0 * r * r * r; }

struct SmoothingReport {
    std::size_t reverted_moves = 0;  ///< vertex moves taken back because a triangle would turn over
};

/// Smooths `mesh` in place with per-vertex `weights` (smoothing_weights; one per vertex).
SmoothingReport smooth_mesh(Mesh& mesh, const std::vector<float>& weights, const SmoothingSettings& settings);

}  // namespace trilevel
