// The level-2 check; see level2_check.hpp.
#include "level2_check.hpp"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/cell_index.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {

namespace {

/// Calls f(corner of the level-2 cube with the lowest coordinates) for each cube of a level-2 cell.
template <class F>
void for_each_level2_cube(const CoarseCell& c, int coarse_steps, F&& f) {
    const glm::ivec3 base = c.coord * coarse_steps;
    for (int z = 0; z < coarse_steps; z += 2)
        for (int y = 0; y < coarse_steps; y += 2)
            for (int x = 0; x < coarse_steps; x += 2) f(base + glm::ivec3(x, y, z));
}

/// Values of one level-2 cell, looked up in two batches (cell_index.hpp): its level-2 points
/// (find_level2_points: (cs/2+1)^3, x fastest) and the centres of its cubes (for_each order).
struct CellValues {
    std::vector<std::uint64_t> keys;
    std::vector<const float*> corners, centres;
};

void look_up(const FinePointMap& field, const CoarseCell& c, int cs, CellValues& v) {
    find_level2_points(field, c.coord, cs, v.keys, v.corners);
    v.keys.clear();
    for_each_level2_cube(c, cs, [&](glm::ivec3 lo) { v.keys.push_back(lattice::pack(lo + glm::ivec3(1))); });
    v.centres.resize(v.keys.size());
    find_batch(field, v.keys.data(), v.keys.size(), v.centres.data());
    for (const auto* list : {&v.corners, &v.centres})
        for (const float* p : *list)
            if (!p) throw Error("level-2 check: a lattice point is missing from the fine point map");
}

/// Whether a cube of the cell (its corner at level-2 index o) is crossed and its centre off the
/// trilinear value.
bool cube_fails(const CellValues& v, int m, glm::ivec3 o, float centre, float tolerance) {
    float sum = 0.0f, lowest = centre, highest = centre;
    for (int k = 0; k < 8; ++k) {
        const glm::ivec3 q = o + glm::ivec3(k & 1, (k >> 1) & 1, (k >> 2) & 1);
        const float value = *v.corners[(q.z * m + q.y) * m + q.x];
        sum += value;
        lowest = std::min(lowest, value);
        highest = std::max(highest, value);
    }
    return lowest < 0.0f && highest >= 0.0f && std::fabs(centre - sum / 8.0f) > tolerance;
}

bool cell_fails(const FinePointMap& field, const CoarseCell& c, int cs, float tolerance, CellValues& v) {
    look_up(field, c, cs, v);
    const int m = cs / 2 + 1;
    std::size_t k = 0;
    bool fails = false;
    for_each_level2_cube(c, cs, [&](glm::ivec3 lo) {
        const glm::ivec3 o = (lo - c.coord * cs) / 2;
        fails = fails || cube_fails(v, m, o, *v.centres[k], tolerance);
        ++k;
    });
    return fails;
}

}  // namespace

std::vector<std::size_t> cells_failing_level2_check(const std::vector<CoarseCell>& cells,
                                                    const std::vector<std::uint8_t>& checked,
                                                    const LatticeFrame& lattice_frame,
                                                    const FinePointMap& field, float tolerance,
                                                    const std::vector<float>& scale) {
    if (checked.size() != cells.size()) throw Error("level-2 check: one flag per cell expected");
    if (!scale.empty() && scale.size() != cells.size()) throw Error("level-2 check: one tolerance factor per cell expected");
    std::vector<std::uint8_t> fails(cells.size(), 0);
    tbb::enumerable_thread_specific<CellValues> scratch;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 256), [&](const auto& range) {
        CellValues& v = scratch.local();
        for (std::size_t i = range.begin(); i != range.end(); ++i)
            if (cells[i].level == 2 && checked[i])
                fails[i] = cell_fails(field, cells[i], lattice_frame.coarse_steps,
                                      scale.empty() ? tolerance : tolerance * scale[i], v);
    });
    std::vector<std::size_t> out;
    for (std::size_t i = 0; i < cells.size(); ++i)
        if (fails[i]) out.push_back(i);
    return out;
}

}  // namespace trilevel
