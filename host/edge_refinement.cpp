#include "edge_refinement.hpp"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "cell_index.hpp"
#include "marching_cubes.hpp"

namespace trilevel {

namespace {

struct Scratch {
    std::vector<std::uint64_t> keys;
    std::vector<const float*> values;
};

/// Midpoints of the crossed level-2 edges of one level-2 cell not in `field` yet. The cell's
/// level-2 values are looked up once, in one batch (each is an end of up to six edges).
bool cell_midpoints(const CoarseCell& cell, int cs, const FinePointMap& field, Scratch& s,
                    std::vector<std::uint64_t>& out) {
    const int m = cs / 2 + 1;  // level-2 points per axis
    const glm::ivec3 base = cell.coord * cs;
    find_level2_points(field, cell.coord, cs, s.keys, s.values);
    const int step[3] = {1, m, m * m};
    bool any = false;
    for (int z = 0, i = 0; z < m; ++z)
        for (int y = 0; y < m; ++y)
            for (int x = 0; x < m; ++x, ++i) {
                const glm::ivec3 o(x, y, z);
                for (int axis = 0; axis < 3; ++axis) {
                    if (o[axis] == m - 1) continue;
                    const float *va = s.values[i], *vb = s.values[i + step[axis]];
                    if (!va || !vb || mc::inside(*va) == mc::inside(*vb)) continue;
                    glm::ivec3 mid = base + 2 * o;
                    mid[axis] += 1;
                    if (!field.find(mid)) out.push_back(lattice::pack(mid)), any = true;
                }
            }
    return any;
}

}  // namespace

Level2Midpoints level2_crossing_midpoints(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                          const FinePointMap& field) {
    tbb::enumerable_thread_specific<std::vector<std::uint64_t>> found;
    tbb::enumerable_thread_specific<Scratch> scratch;
    std::vector<std::uint8_t> holds(cells.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 64), [&](const auto& range) {
        auto& out = found.local();
        auto& s = scratch.local();
        for (std::size_t i = range.begin(); i != range.end(); ++i)
            if (cells[i].level == 2) holds[i] = cell_midpoints(cells[i], frame.coarse_steps, field, s, out);
    });
    Level2Midpoints out;
    for (auto& v : found) out.keys.insert(out.keys.end(), v.begin(), v.end());
    std::sort(out.keys.begin(), out.keys.end());
    out.keys.erase(std::unique(out.keys.begin(), out.keys.end()), out.keys.end());
    for (std::size_t i = 0; i < cells.size(); ++i)
        if (holds[i]) out.holders.push_back(cells[i]);
    return out;
}

}  // namespace trilevel
