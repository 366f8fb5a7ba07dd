#include "edge_refinement.hpp"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "cell_index.hpp"
#include "marching_cubes.hpp"

namespace trilevel {

namespace {

struct Scratch {
    std::vector<std::uint64_t> keys, mids;
    std::vector<const float*> values, found;
};

/// Midpoints of the crossed level-2 edges of one level-2 cell not in `field` yet, tagged with the
/// cell's index. The cell's level-2 values are looked up once, in one batch (each is an end of up
/// to six edges).
void cell_midpoints(const CoarseCell& cell, std::uint32_t index, int cs, const FinePointMap& field, Scratch& s,
                    std::vector<std::pair<std::uint64_t, std::uint32_t>>& out) {
    const int m = cs / 2 + 1;  // level-2 points per axis
    const glm::ivec3 base = cell.coord * cs;
    find_level2_points(field, cell.coord, cs, s.keys, s.values);
    const int step[3] = {1, m, m * m};
    s.mids.clear();
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
                    s.mids.push_back(lattice::pack(mid));
                }
            }
    s.found.resize(s.mids.size());
    find_batch(field, s.mids.data(), s.mids.size(), s.found.data());  // their misses overlap
    for (std::size_t k = 0; k < s.mids.size(); ++k)
        if (!s.found[k]) out.emplace_back(s.mids[k], index);
}

}  // namespace

Level2Midpoints level2_crossing_midpoints(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                          const FinePointMap& field) {
    using Tagged = std::pair<std::uint64_t, std::uint32_t>;  // key, index of a cell holding it
    tbb::enumerable_thread_specific<std::vector<Tagged>> found;
    tbb::enumerable_thread_specific<Scratch> scratch;
    // Visited in Morton order, so that neighbouring cells, which share most level-2 points, run
    // close in time; the lists below do not depend on the order of the visit.
    std::vector<std::uint32_t> visit;
    for (std::size_t i = 0; i < cells.size(); ++i)
        if (cells[i].level == 2) visit.push_back(std::uint32_t(i));
    lattice::sort_by_morton(visit, [&](std::uint32_t i) { return cells[i].coord; });
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, visit.size(), 64), [&](const auto& range) {
        auto& out = found.local();
        auto& s = scratch.local();
        for (std::size_t k = range.begin(); k != range.end(); ++k)
            cell_midpoints(cells[visit[k]], visit[k], frame.coarse_steps, field, s, out);
    });
    std::size_t total = 0;
    for (auto& v : found) total += v.size();
    std::vector<Tagged> all;  // ~1.3 M at x512: reserved once, each thread's list freed as it is copied
    all.reserve(total);
    std::vector<std::uint8_t> holds(cells.size(), 0);
    for (auto& v : found) {
        for (const Tagged& t : v) holds[t.second] = 1;
        all.insert(all.end(), v.begin(), v.end());
        std::vector<Tagged>().swap(v);
    }
    tbb::parallel_sort(all.begin(), all.end());  // by key, then cell: the first cell of each key keeps it
    all.erase(std::unique(all.begin(), all.end(), [](const Tagged& a, const Tagged& b) { return a.first == b.first; }),
              all.end());
    // Grouped by cell in cells order by a counting pass; `all` is in key order, so each cell's keys
    // stay in key order.
    std::vector<std::uint32_t> next(cells.size(), 0);
    for (const Tagged& t : all) ++next[t.second];
    Level2Midpoints out;
    std::uint32_t at = 0;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        const std::uint32_t count = next[i];
        next[i] = at;
        if (!holds[i]) continue;
        out.holders.push_back(cells[i]);
        out.first.push_back(at);
        at += count;
    }
    out.first.push_back(at);
    out.keys.resize(all.size());
    for (const Tagged& t : all) out.keys[next[t.second]++] = t.first;
    return out;
}

}  // namespace trilevel
