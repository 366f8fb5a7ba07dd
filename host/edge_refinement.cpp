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
    std::vector<std::uint64_t> keys, mids;
    std::vector<const float*> values, found;
};

/// Whether `cell` is the first of `cells` (key order: z, then y, then x) among the level-2 cells
/// holding the level-2 edge with midpoint `mid` (fine lattice). Up to four cells hold an edge on
/// a cell face or edge; each holds its crossing (the same two end values) and misses its midpoint
/// alike, so the first of them lists it.
bool first_holder(glm::ivec3 cell, glm::ivec3 mid, int cs, const CellIndex& index) {
    glm::ivec3 other(0);  // per axis: -1 or +1 where the edge lies on the cell's low or high face
    for (int a = 0; a < 3; ++a) other[a] = mid[a] == cell[a] * cs ? -1 : mid[a] == (cell[a] + 1) * cs ? 1 : 0;
    for (int dz = std::min(other.z, 0); dz <= std::max(other.z, 0); ++dz)
        for (int dy = std::min(other.y, 0); dy <= std::max(other.y, 0); ++dy)
            for (int dx = std::min(other.x, 0); dx <= std::max(other.x, 0); ++dx) {
                const bool earlier = dz < 0 || (dz == 0 && (dy < 0 || (dy == 0 && dx < 0)));
                if (earlier && index.level(cell + glm::ivec3(dx, dy, dz)) == 2) return false;
            }
    return true;
}

/// Midpoints of the crossed level-2 edges of one level-2 cell not in `field` yet, those the cell
/// lists (first_holder) tagged with its index, in ascending key order. Returns whether the cell
/// holds any. The cell's level-2 values are looked up once, in one batch (each is an end of up
/// to six edges).
bool cell_midpoints(const CoarseCell& cell, std::uint32_t index, int cs, const FinePointMap& field,
                    const CellIndex& cells, Scratch& s, std::vector<std::pair<std::uint64_t, std::uint32_t>>& out) {
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
    bool holds = false;
    const std::size_t first = out.size();
    for (std::size_t k = 0; k < s.mids.size(); ++k) {
        if (s.found[k]) continue;
        holds = true;
        if (first_holder(cell.coord, lattice::unpack(s.mids[k]), cs, cells)) out.emplace_back(s.mids[k], index);
    }
    std::sort(out.begin() + std::ptrdiff_t(first), out.end());
    return holds;
}

}  // namespace

Level2Midpoints level2_crossing_midpoints(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                          const FinePointMap& field) {
    using Tagged = std::pair<std::uint64_t, std::uint32_t>;  // key, index of the cell listing it
    tbb::enumerable_thread_specific<std::vector<Tagged>> found;
    tbb::enumerable_thread_specific<Scratch> scratch;
    const CellIndex index(cells);
    std::vector<std::uint8_t> holds(cells.size(), 0);
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
            holds[visit[k]] = cell_midpoints(cells[visit[k]], visit[k], frame.coarse_steps, field, index, s, out);
    });
    // Grouped by cell in cells order by a counting pass; each cell's keys are contiguous in one
    // thread's list, in ascending order, and stay so.
    std::vector<std::uint32_t> next(cells.size(), 0);
    for (const auto& v : found)
        for (const Tagged& t : v) ++next[t.second];
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
    out.keys.resize(at);
    for (auto& v : found) {
        for (const Tagged& t : v) out.keys[next[t.second]++] = t.first;
        std::vector<Tagged>().swap(v);
    }
    return out;
}

}  // namespace trilevel
