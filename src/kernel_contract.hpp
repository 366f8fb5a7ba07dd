// The host side of the host-kernel contract (kernels/contract.h): the same values as C++
// constants and types, so that host code never repeats a kernel's number.
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/contract.h"

namespace trilevel::contract {

/// Particle flags (ParticleClasses::flags, one byte a sorted particle).
constexpr std::uint8_t kFlagSurface = FLAG_SURFACE;
constexpr std::uint8_t kFlagSplash = FLAG_SPLASH;
constexpr std::uint8_t kFlagThin = FLAG_THIN;

/// Coarse cell flags (one uint a cell slot).
constexpr std::uint32_t kCellSplash = CELL_SPLASH;
constexpr std::uint32_t kCellThinBody = CELL_THIN_BODY;

/// The w of a cell in the device's int4 cell lists: level | kCellCubeCentres.
constexpr std::int32_t kCellLevelMask = CELL_LEVEL_MASK;
constexpr std::int32_t kCellCubeCentres = CELL_CUBE_CENTRES;
constexpr int kCellAboveShift = CELL_ABOVE_SHIFT;

/// __local list lengths the host allocates for the kernels.
constexpr std::size_t kMaxBins = MAX_BINS;
constexpr std::size_t kMaxCellPoints = MAX_CELL_POINTS;
/// Length of each of scalar_field_cells' three candidate coordinate columns (CANDIDATE_COLUMN in
/// scalar_field.cl): the candidate limit rounded up to whole vectors of 8.
constexpr std::size_t candidate_column(std::size_t max_candidates) { return (max_candidates + 7) / 8 * 8; }

/// Which pending points of its cell a work-group of scalar_field_cells claims.
enum class ClaimPoints : std::int32_t {
    Level = CLAIM_LEVEL,                  ///< the points of the cell's level (and its cube centres where flagged)
    EdgeMidpoints = CLAIM_EDGE_MIDPOINTS, ///< midpoints of level-2 edges left pending (edge refinement)
    Inserted = CLAIM_INSERTED,            ///< inserts the points of its level and takes those it created
    RefinedEdges = CLAIM_REFINED_EDGES,   ///< inserts the midpoints of its crossed level-2 edges, takes those it created
};

/// Whether a pass of this mode inserts the points it evaluates.
constexpr bool inserts(ClaimPoints c) { return c == ClaimPoints::Inserted || c == ClaimPoints::RefinedEdges; }

}  // namespace trilevel::contract

// The kernels' spellings stay in the .cl files and in the constants above.
#undef FLAG_SURFACE
#undef FLAG_SPLASH
#undef FLAG_THIN
#undef CELL_SPLASH
#undef CELL_LEVEL_MASK
#undef CELL_CUBE_CENTRES
#undef CELL_ABOVE_SHIFT
#undef MAX_BINS
#undef MAX_CELL_POINTS
#undef CLAIM_LEVEL
#undef CLAIM_EDGE_MIDPOINTS
#undef CLAIM_INSERTED
#undef CLAIM_REFINED_EDGES
#undef KAPPA_FIXED
