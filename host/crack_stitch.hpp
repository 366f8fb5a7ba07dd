// Crack closing on transition faces (paper §3.3.2, generalised as in docs/design.md §7).
#pragma once

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "core/coarse_cells.hpp"
#include "core/fine_point_map.hpp"

namespace trilevel {

/// A level-3 cell as the surface mesher gathered it: values and vertex slots of its
/// (n+1)^3 lattice points (x fastest), n = coarse_steps.
struct Level3Block {
    glm::ivec3 base{0};               ///< lattice coordinates of local point (0,0,0)
    int n = 0;                        ///< coarse_steps
    const float* values = nullptr;    ///< field value per local point
    const std::int32_t* slots = nullptr;    ///< vertex id per (local point * 3 + axis) unit edge, or -1
    const glm::vec3* positions = nullptr;   ///< vertex positions by vertex id
};

/// Closes the crack on face (axis, side) of a level-3 cell whose neighbour there is level 2:
/// per level-2 fine face, the level-2 face segments and the four level-3 face segments form
/// disjoint cycles of vertex ids; each cycle longer than 2 is triangulated in the face plane by
/// ear clipping, opposite to its edges, avoiding diagonals that the adjacent cubes already use.
/// Appends patch triangles (vertex ids, three per triangle) to `out`; returns how many. Also
/// appends to `runs` each polygon's level-3 runs between two level-2 crossings that hold inner
/// crossings, for collapse_crack_runs (host/crack_collapse.hpp).
/// `field` supplies the level-2 cube's values off the face. Throws Error on a broken invariant.
std::size_t stitch_transition_face(const Level3Block& block, int axis, int side, const FinePointMap& field,
                                   std::vector<std::uint32_t>& out, std::vector<std::uint32_t>& runs);

}  // namespace trilevel
