// The sparse set of coarse surface cells handed from the device stages to the host stages.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "core/lattice.hpp"

namespace trilevel {

/// One coarse surface cell (paper Fig. 1). Its lattice points are
/// coord * coarse_steps + [0, coarse_steps] per axis, every `stride(level)`-th one.
struct CoarseCell {
    glm::ivec3 coord{0};     ///< integer coarse-cell coordinates (>= 0)
    std::uint8_t level = 3;  ///< 2: refined with stride 2 (cells of 2 lattice steps); 3: stride 1
};

inline int stride(std::uint8_t level) { return level == 2 ? 2 : 1; }

/// Geometry of the lattice: where point (0,0,0) is and how far apart points are.
struct LatticeFrame {
    glm::vec3 origin{0.0f};  ///< world position of lattice point (0,0,0)
    float step = 1.0f;       ///< world distance between neighbouring lattice points
    int coarse_steps = 4;    ///< lattice steps per coarse cell edge (even)
    lattice::KeyLayout keys;  ///< how the fine-point table stores its points (default: 64-bit pack())
};

}  // namespace trilevel
