// Crack closing by collapse (docs/design.md §7, beyond the paper's §3.3.2): the inner crossings of a
// transition face are merged into the level-2 crossings beside them, which removes the crack
// patches instead of adding them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel {

/// The level-3 side of one crack polygon between two level-2 crossings: vertex ids
/// [a, v1, ..., vk, b], where a and b are crossings of the level-2 face segment (shared with the
/// level-2 cube) and v1..vk crossings of the face's inner half-edges, which only the level-3 cell
/// uses. Flattened as (k + 2, a, v1, ..., vk, b) per run.
using CrackRuns = std::vector<std::uint32_t>;

/// Collapses each run's inner vertices, from the ends inwards, into the nearer of a and b: the
/// crack patch and the level-3 triangle on the collapsed edge vanish, the vertex's other triangles
/// take a or b instead. A closed mesh has two triangles fewer per vertex it loses (Euler), so this
/// is what a crack costs beyond the level-2 face segment. A collapse is made only where it keeps
/// the mesh a closed oriented 2-manifold (link condition: the two ends share no neighbour but the
/// two apexes of the edge) and flips no triangle; otherwise the patch stays. Runs are taken in
/// their given order, so the result is deterministic. Removes the dead vertices and triangles
/// (order of the rest kept) and returns how many vertices were collapsed. `kept`, where given,
/// receives the old index of each vertex left, ascending (no vertex moves).
std::size_t collapse_crack_runs(Mesh& mesh, const CrackRuns& runs, std::vector<std::uint32_t>* kept = nullptr);

}  // namespace trilevel
