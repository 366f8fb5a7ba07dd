// Splitting a particle set too wide for one lattice (lattice.hpp: 20 bits per axis) into groups
// that are reconstructed on lattices of their own and whose meshes are concatenated.
//
// Why it is exact: particles further apart than the interaction distance (the kernel radius, plus
// the coarse cells a particle marks, their 3x3x3 curvature blocks and band closure) share no
// neighbour sum, no coarse cell and no cell face, so their surfaces are independent, and the union
// of closed meshes is closed. Each group's lattice origin is a multiple of the coarse cell edge, as
// in the single-lattice case, so the cells are the same ones; only float rounding of positions
// relative to the origin differs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace trilevel {

/// `v` with 3 significant digits (%.3g), for error messages.
std::string fmt(double v);

/// Axis-aligned bounds of a particle set, in double precision.
struct Bounds {
    double lo[3], hi[3];
    double max_abs = 0.0;  ///< largest |coordinate|: sets the float resolution of the input
};

/// Bounds of `n` particles; Error naming the first particle with a non-finite coordinate.
Bounds bounds_of(const float* xyz, std::size_t n);

/// Particle indices (ascending) of each group, in a deterministic order.
///  - `separation`: particles at least this far apart never interact (world units).
///  - `tile`: half the width one lattice holds (world units); a group spans at most 2 * tile.
/// A connected cluster (links shorter than `separation`) wider than 2 * tile is an Error.
std::vector<std::vector<std::uint32_t>> split_domain(const float* xyz, std::size_t n, double separation, double tile);

}  // namespace trilevel
