// The level-2 check; see level2_check.hpp.
#include "level2_check.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

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

float value_at(const FinePointMap& field, glm::ivec3 p) {
    const float* v = field.find(p);
    if (!v) throw Error("level-2 check: a lattice point is missing from the fine point map");
    return *v;
}

/// Whether the cube at `lo` (edge 2 steps) is crossed and its centre off the trilinear value.
bool cube_fails(const FinePointMap& field, glm::ivec3 lo, float tolerance) {
    float sum = 0.0f, lowest, highest;
    const float centre = value_at(field, lo + glm::ivec3(1));
    lowest = highest = centre;
    for (int k = 0; k < 8; ++k) {
        const float v = value_at(field, lo + 2 * glm::ivec3(k & 1, (k >> 1) & 1, (k >> 2) & 1));
        sum += v;
        lowest = std::min(lowest, v);
        highest = std::max(highest, v);
    }
    return lowest < 0.0f && highest >= 0.0f && std::fabs(centre - sum / 8.0f) > tolerance;
}

}  // namespace

std::vector<std::uint64_t> level2_check_points(const std::vector<CoarseCell>& cells, const LatticeFrame& frame) {
    std::vector<std::uint64_t> keys;
    for (const auto& c : cells)
        if (c.level == 2)
            for_each_level2_cube(c, frame.coarse_steps, [&](glm::ivec3 lo) { keys.push_back(lattice::pack(lo + glm::ivec3(1))); });
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    return keys;
}

std::vector<std::size_t> cells_failing_level2_check(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                                    const FinePointMap& field, float tolerance) {
    std::vector<std::uint8_t> fails(cells.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 256), [&](const auto& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
            if (cells[i].level != 2) continue;
            bool f = false;
            for_each_level2_cube(cells[i], frame.coarse_steps, [&](glm::ivec3 lo) { f = f || cube_fails(field, lo, tolerance); });
            fails[i] = f;
        }
    });
    std::vector<std::pair<std::uint64_t, std::size_t>> by_key(cells.size());
    for (std::size_t i = 0; i < cells.size(); ++i) by_key[i] = {lattice::pack(cells[i].coord), i};
    std::sort(by_key.begin(), by_key.end());
    std::vector<std::uint8_t> promote(cells.size(), 0);
    for (std::size_t i = 0; i < cells.size(); ++i) {
        if (!fails[i]) continue;
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const glm::ivec3 q = cells[i].coord + glm::ivec3(dx, dy, dz);
                    if (glm::any(glm::lessThan(q, glm::ivec3(0)))) continue;
                    const std::uint64_t key = lattice::pack(q);
                    auto it = std::lower_bound(by_key.begin(), by_key.end(), std::make_pair(key, std::size_t(0)));
                    if (it != by_key.end() && it->first == key && cells[it->second].level == 2) promote[it->second] = 1;
                }
    }
    std::vector<std::size_t> out;
    for (std::size_t i = 0; i < cells.size(); ++i)
        if (promote[i]) out.push_back(i);
    return out;
}

}  // namespace trilevel
