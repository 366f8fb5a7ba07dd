// Transition continuity (paper §3.3.1, DESIGN §7); see transition_continuity.hpp.
#include "transition_continuity.hpp"

#include <atomic>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "trilevel/trilevel.hpp"

namespace trilevel {
namespace {

float level2_value(const FinePointMap& field, glm::ivec3 p) {
    const float* v = field.find(p);
    if (!v) throw Error("transition continuity: level-2 lattice point missing from the fine point map");
    return *v;
}

// The interpolated value of an off-lattice boundary point `p` (DESIGN §7).
float interpolated_value(const FinePointMap& field, glm::ivec3 p) {
    int odd[2], n = 0;
    for (int a = 0; a < 3; ++a)
        if (p[a] & 1) odd[n++] = a;
    glm::ivec3 e0{0}, e1{0};
    e0[odd[0]] = 1;
    if (n == 1) return lattice::edge_midpoint_value(level2_value(field, p - e0), level2_value(field, p + e0));
    e1[odd[1]] = 1;
    return lattice::face_centre_value(level2_value(field, p - e0 - e1), level2_value(field, p + e0 - e1),
                                      level2_value(field, p - e0 + e1), level2_value(field, p + e0 + e1));
}

// All odd points of the closed boundary of one level-2 cell that the map holds.
void fix_cell(const CoarseCell& cell, int cs, FinePointMap& field) {
    const glm::ivec3 base = cell.coord * cs;
    for (int axis = 0; axis < 3; ++axis) {
        const int b = (axis + 1) % 3, c = (axis + 2) % 3;
        for (int side = 0; side < 2; ++side)
            for (int j = 0; j <= cs; ++j)
                for (int i = 0; i <= cs; ++i) {
                    if (((i | j) & 1) == 0) continue;
                    glm::ivec3 p = base;
                    p[axis] += side * cs;
                    p[b] += i;
                    p[c] += j;
                    float* v = field.find(p);
                    if (!v) continue;
                    // Cells sharing the point store the same value: relaxed atomic stores keep it race-free.
                    std::atomic_ref<float>(*v).store(interpolated_value(field, p), std::memory_order_relaxed);
                }
    }
}

}  // namespace

void apply_transition_continuity(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                 FinePointMap& field) {
    if (frame.coarse_steps % 2 != 0) throw Error("transition continuity: coarse_steps must be even");
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 256), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
            if (cells[i].level == 2) fix_cell(cells[i], frame.coarse_steps, field);
    });
}

}  // namespace trilevel
