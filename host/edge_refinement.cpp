#include "edge_refinement.hpp"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "marching_cubes.hpp"

namespace trilevel {

Level2Midpoints level2_crossing_midpoints(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                          const FinePointMap& field) {
    const int cs = frame.coarse_steps;
    tbb::enumerable_thread_specific<std::vector<std::uint64_t>> found;
    std::vector<std::uint8_t> holds(cells.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 64), [&](const auto& range) {
        auto& out = found.local();
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
            if (cells[i].level != 2) continue;
            const glm::ivec3 base = cells[i].coord * cs;
            for (int z = 0; z <= cs; z += 2)
                for (int y = 0; y <= cs; y += 2)
                    for (int x = 0; x <= cs; x += 2) {
                        const glm::ivec3 p = base + glm::ivec3(x, y, z);
                        const float* va = field.find(p);
                        if (!va) continue;
                        for (int axis = 0; axis < 3; ++axis) {
                            if (glm::ivec3(x, y, z)[axis] == cs) continue;
                            glm::ivec3 q = p;
                            q[axis] += 2;
                            const float* vb = field.find(q);
                            if (!vb || mc::inside(*va) == mc::inside(*vb)) continue;
                            glm::ivec3 mid = p;
                            mid[axis] += 1;
                            if (!field.find(mid)) out.push_back(lattice::pack(mid)), holds[i] = 1;
                        }
                    }
        }
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
