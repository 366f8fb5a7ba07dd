// Smoothing of a reconstructed mesh (Params::smooth): weighted Laplacian smoothing in the manner
// of Löschner, Böttcher, Jeske and Bender, "Weighted Laplacian Smoothing for Surface
// Reconstruction of Particle-based Fluids" (VMV 2023): each vertex moves towards the mean of its
// neighbours by a weight taken from the particles around it, so that surfaces of splash and thin
// particles (few neighbours) barely move while the bumps of the bulk's particles are ironed out.
// The curvature-following shrink of the Laplacian steps is given back along the normals (its
// wide-neighbourhood average), and a final correction along the normals restores each connected
// component's volume exactly (to rounding). Only positions change, never the index topology, so
// a closed oriented mesh stays closed and oriented; a step that would turn a triangle over
// (against its orientation before smoothing) is taken back at that triangle's corners.
// Every vertex is computed on its own over a fixed adjacency, and per-component sums run in
// triangle order: the same bits at any thread count.
#pragma once

#include <cstddef>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel {

/// Weight of each vertex in [0, 1]: with n_j the number of particles within R of particle j, the
/// kernel-weighted mean n(v) = sum_j k_j n_j / sum_j k_j over the particles j within R of v
/// (k_j = (1 - |v - x_j|^2 / R^2)^3, the field's kernel), and w(v) = smoothstep(min(1, n(v) / n_half)),
/// n_half = half the neighbours of a particle at rest spacing 2r ((2 pi / 3) (R / 2r)^3).
/// A vertex without particles within R gets 0. `xyz`: `count` particles, world units.
std::vector<float> smoothing_weights(const Mesh& mesh, const float* xyz, std::size_t count, float r, float R);

struct SmoothingSettings {
    int iterations = 0;        ///< Laplacian steps (with mu != 0: lambda/mu pairs); 0: no smoothing
    /// Step towards the weighted neighbours' mean. 0.5 with 25 steps as splashsurf's default.
    double lambda = 0.5;
    /// Taubin's inflating step after each lambda step; 0: none. Measured on the jittered analytic
    /// bodies (bench/RESULTS-smoothing.md) Taubin pairs leave the particle bumps, whose wavelength
    /// of a few edges lies in Taubin's pass band, and amplify them for |mu| > 0.55: off by default.
    double mu = 0.0;
    /// Rounds of 1-ring averaging that estimate the curvature shrink given back at the end (see
    /// mesh_smoothing.cpp); 0: none.
    int shrink_passes = 30;
    bool keep_volume = true;   ///< restore each component's volume along the normals at the end
};

struct SmoothingReport {
    std::size_t reverted_moves = 0;  ///< vertex moves taken back because a triangle would turn over
    double volume_before = 0, volume_after = 0;  ///< of the whole mesh, world units
};

/// Smooths `mesh` in place with per-vertex `weights` (smoothing_weights; one per vertex).
SmoothingReport smooth_mesh(Mesh& mesh, const std::vector<float>& weights, const SmoothingSettings& settings);

}  // namespace trilevel
