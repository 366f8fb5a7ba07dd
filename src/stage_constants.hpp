// Constants and formulas shared by the OpenCL stages and their C++ references (docs/design.md §3).
// The kernels receive these values as build options; change them here only.
#pragma once

#include <cstddef>

namespace trilevel::constants {

/// Surface particle test (docs/design.md §3.1): |n_i| * R > kSurfaceGradient, with n_i the colour-field
/// gradient with poly6 weights and particle volume V = (2r)^3. Calibrated on jittered lattice
/// blocks (tests/test_reference_stages.cpp, "[calibration]"): every particle within one spacing of a
/// face is surface, none deeper than R is; 0.55 is the middle of the gap between the outer layer's
/// values and the deeper ones' (docs/calibration.md, "Measurements behind the stage constants").
constexpr float kSurfaceGradient = 0.55f;

/// Splash particle: fewer than this many neighbours within R, itself excluded (paper §3).
constexpr int kSplashNeighbours = 3;

/// Thin particle: fewer than this many neighbours within R. Small clusters, filaments and sheets
/// one particle thick vanish or break on a lattice of 2r, so cells near them are level 3 like
/// splash cells (paper Fig. 1: "cells around the isolated pieces are always level-3"). Calibrated on
/// the dam-break frames: 5 lost a small cluster, 8 promoted more cells for no accuracy (docs/calibration.md).
constexpr int kThinNeighbours = 6;

/// Sheet particle: no surface gradient (its neighbours balance on both sides) and fewer neighbours
/// than this fraction of a particle inside the fluid has, (4 pi / 3) R^3 / (2r)^3 (33.5 at R = 4r).
/// A sheet one particle thick has about pi (R / 2r)^2 (12.6), and no particle of a surface: its
/// layer of 2r samples lies about r off the sheet's middle on both sides, so the level-2 lattice
/// sees the sheet as surface everywhere and tears it into islands (a generated 40 x 1 x 40 sheet:
/// 45 components, 31% of the volume lost). Sheet particles are thin: level 3 around them. 0.4
/// (13.4) takes every particle of such a sheet and no particle of a flat face or of the dam-break
/// frames' bulk (docs/calibration.md, "Sheets one particle thick").
constexpr float kSheetNeighbourFraction = 0.4f;

/// The neighbour count below which a particle without surface gradient is a sheet particle, for
/// support R and particle volume (2r)^3 (the colour-field kernel takes it as an argument).
inline float sheet_neighbour_limit(float R, float volume) {
    return kSheetNeighbourFraction * (4.0f * 3.14159265f / 3.0f) * R * R * R / volume;
}

/// Neighbours closer than kSameSpot * R count as the same spot, not as neighbours, in the splash and
/// thin tests. Particles stacked on one point have a zero colour-field gradient, so a pile of them
/// would otherwise be neither surface nor splash and vanish from the mesh; 1/4096 R (0.001 r at
/// R = 4r) is far below any spacing real frames show (the closest pair in the shared frames: 0.005 r).
constexpr float kSameSpot = 1.0f / 4096.0f;
/// A particle whose neighbours within R lie within kPileFraction * R of it (r at R = 4r) in the root
/// mean square, itself counted, is splash: its neighbourhood is one spot at the kernel's scale.
/// Tested as sum(R^2 - d^2) >= (neighbours + 1) (1 - kPileFraction^2) R^2 over the particle and
/// its neighbours (one add a candidate; same-spot neighbours only add to the sum). A pile spread
/// that little has next to no colour-field gradient (its particles see each other almost on the
/// spot), so it would be neither surface nor splash: 160 particles within 0.01 r gave no surface
/// cell at all. Real fluid has its neighbours spread over R (rest spacing 2r): no frame changes.
constexpr float kPileFraction = 0.25f;

/// Surface cells: coarse cells overlapping the box x_i ± kSurfaceBoxHalf * r around each surface or
/// splash particle (paper §3, after Akinci et al. 2012: an AABB of 4r around each surface particle).
constexpr float kSurfaceBoxHalf = 2.0f;

/// First capacity of the coarse cell hash, per surface or splash particle: large frames have about
/// 0.3 coarse cells per surface particle, so their table starts at load <= 1/2 and is filled once;
/// small splashy scenes grow it (docs/design.md §5). Not larger: every per-cell buffer of stage 4
/// and every host read of them is as long as the table (docs/calibration.md).
constexpr float kCoarseCellsPerSurfaceParticle = 0.75f;

/// First capacity of the particle-bin hash, per particle (rounded up to a power of two). A bin of
/// edge R = 4r holds 8 particles of a lattice of spacing 2r, so the table starts at load 0.14-0.5 on
/// the dam-break frames and sparse scenes grow it once (docs/calibration.md).
constexpr float kBinSlotsPerParticle = 0.125f;

/// Memory a splash particle far from every other costs when meshed as a droplet of its own, a lower
/// bound: 64 k particles 20 r apart made 6.9 coarse cells, 556 fine points, 48 triangles and 9.6 KB
/// of peak memory each. Frames whose particles are mostly such are refused up front when this many
/// bytes a particle exceed the host budget (a radius far too small: 4.1 M particles ran 50 s before
/// a buffer failed).
constexpr double kBytesPerLoneParticle = 8192.0;

/// Splash cells: surface cells overlapping x_i ± kSplashBoxHalf * r around a splash or thin particle
/// (the same box that makes surface cells: the cells that hold its blob). Wider boxes (e.g. ±R)
/// turned many more cells level 3 around droplets near the main surface, each adding crack patches,
/// without lowering the deviation from the uniform r mesh (bench/RESULTS.md, calibration).
constexpr float kSplashBoxHalf = 2.0f;

/// Isolated pieces: a group of at most this many coarse surface cells joined by shared faces is
/// meshed at level 3 whatever its curvature (paper Fig. 1: "cells around the isolated pieces are
/// always level-3"; host/isolated_pieces.hpp). A compact droplet of n particles makes a group of 8
/// (n = 8), 26 (19), 39 (33) and 54 (81) cells, and level 2 gave it 64%, 86%, 89% and 95% of uniform
/// r's volume: its curvature, a sum over few neighbours (paper eq. 1), stays under the threshold, and
/// its particles have too many neighbours to be thin. 64 takes droplets of up to about 100
/// particles; on x64 it turns 1,501 of 128,577 cells level 3 for 1.1% more triangles
/// (docs/calibration.md).
constexpr std::size_t kIsolatedPieceCells = 64;

/// Passes of the 3x3x3 block mean over the cell curvatures before the threshold (beyond the paper;
/// kernels/curvature.cl, smooth_cell_curvature). One pass left level regions ragged where the
/// curvature is noisy (disordered particles: flat water of the x8 resampling sits at about the
/// threshold); three (an effective 7x7x7 tent) made them compact, with fewer crack patches
/// (docs/calibration.md, "Measurements behind the stage constants").
constexpr int kCurvatureSmoothingPasses = 3;
static_assert(kCurvatureSmoothingPasses >= 1, "the last pass writes the cell curvature the levels read");

/// Host bytes the triangulation may take per fine point, checked against the memory budget before
/// it runs: vertices and triangles are a fraction of the fine points (< 1 vertex and < 2 triangles
/// per point on every scene measured); 40 bytes a point bound the mesh and its edge maps.
constexpr double kMeshBytesPerFinePoint = 40.0;

/// The level-2 check (host/level2_check.hpp) examines only level-2 cells whose cell curvature is
/// at least this, or that belong to a thin body (kThinBodyTolerance): below it the particles say
/// flat and ordered and the level-2 lattice is trusted (on ordered frames the field ripples at the
/// particle spacing, and checking there only promotes cells); disordered flat water sits above it,
/// so there the check still decides (docs/calibration.md, "Levels and choosing the threshold" and
/// "Measurements behind the stage constants").
constexpr float kLevel2CheckCurvature = 3.0f;

/// Cells of a thin body, none of whose 3x3x3 block holds a particle inside the fluid (a rod,
/// torus or sheet a few particles thick, a droplet), are checked whatever their curvature, at this
/// fraction of the level-2 tolerance. A 2r lattice thins such a body everywhere by a little under
/// the tolerance: rods and tori of radius 2r (cell curvature 2.5-3) kept 78-99% of uniform r's
/// volume with p99 deviations up to 1.1 r; with the rule 99.3-100% at p99 0.2 r (docs/calibration.md).
constexpr float kThinBodyTolerance = 0.6f;

/// Calibrated default of the curvature threshold (docs/calibration.md, "Levels and choosing the threshold"),
/// with the level-2 check on at its default tolerance (Params::level2_tolerance, 0.32 r): cells above
/// it are level 3 outright, cells from kLevel2CheckCurvature to it are checked. The check measures
/// the lattice error itself, so the threshold only sends clearly curved cells ahead (without the
/// check, tolerance 0, a lower threshold is needed: docs/calibration.md).
constexpr float kDefaultCurvatureThreshold = 8.0f;

/// The scalar field's support ends where q = 1 - s^2 falls to kSupportCut (s = |x - x_j| / R above
/// 0.999), not at s = 1: k_j there is under 1e-8 of its peak. The cut keeps every particle a fine
/// point sees R/1000 inside the 27 particle bins around the point's coarse cell whatever the float
/// rounding of binning (up to 8000 bins from the lattice origin), so the per-cell kernel gathers
/// those 27 bins instead of 4-5 per axis, and a point shared by cells gets the same bits from each.
constexpr float kSupportCut = 1.0f / 512.0f;

/// Solenthaler et al. 2007 eigenvalue thresholds (docs/design.md §3.3).
constexpr float kEvLow = 0.4f;
constexpr float kEvHigh = 3.5f;

/// Coarse cell edge in particle radii (docs/design.md §2).
constexpr float kCoarseCell = 4.0f;

}  // namespace trilevel::constants
