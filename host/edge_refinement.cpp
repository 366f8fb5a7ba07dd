#include "edge_refinement.hpp"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "marching_cubes.hpp"

namespace trilevel {

std::vector<std::uint64_t> level2_crossing_midpoints(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                                     const FinePointMap& field) {
    const int cs = frame.coarse_steps;
    tbb::enumerable_thread_specific<std::vector<std::uint64_t>> found;
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
                            if (!field.find(mid)) out.push_back(lattice::pack(mid));
                        }
                    }
        }
    });
    std::vector<std::uint64_t> keys;
    for (auto& v : found) keys.insert(keys.end(), v.begin(), v.end());
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    return keys;
}

}  // namespace trilevel
