// The level-2 edge refinement's definition; see edge_refinement.hpp.
#include "reference/edge_refinement.hpp"

#include <algorithm>

#include "marching_cubes.hpp"

namespace trilevel {

std::vector<std::uint64_t> edge_refinement_points(const std::vector<CoarseCell>& cells,
                                                  const LatticeFrame& lattice_frame, const FinePointMap& field) {
    const int cs = lattice_frame.coarse_steps;
    std::vector<std::uint64_t> out;
    for (const CoarseCell& cell : cells) {
        if (cell.level != 2) continue;
        const glm::ivec3 base = cell.coord * cs;
        for (int z = 0; z <= cs; z += 2)
            for (int y = 0; y <= cs; y += 2)
                for (int x = 0; x <= cs; x += 2)
                    for (int axis = 0; axis < 3; ++axis) {
                        glm::ivec3 a = base + glm::ivec3(x, y, z), b = a;
                        if (b[axis] + 2 > base[axis] + cs) continue;
                        b[axis] += 2;
                        const float *va = field.find(lattice::pack(a)), *vb = field.find(lattice::pack(b));
                        if (!va || !vb || mc::inside(*va) == mc::inside(*vb)) continue;
                        glm::ivec3 mid = a;
                        mid[axis] += 1;
                        if (!field.find(lattice::pack(mid))) out.push_back(lattice::pack(mid));
                    }
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

}  // namespace trilevel
