// Band closure (DESIGN §7); see band_closure.hpp.
#include "band_closure.hpp"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "trilevel/trilevel.hpp"

namespace trilevel {
namespace {

// Does face (axis, side) of `cell` hold both signs at the cell's stride?
bool face_is_crossed(const CoarseCell& cell, int axis, int side, int cs, const FinePointMap& field) {
    const int b = (axis + 1) % 3, c = (axis + 2) % 3, st = stride(cell.level);
    bool any_in = false, any_out = false;
    for (int j = 0; j <= cs; j += st)
        for (int i = 0; i <= cs; i += st) {
            glm::ivec3 p = cell.coord * cs;
            p[axis] += side * cs;
            p[b] += i;
            p[c] += j;
            const float* v = field.find(p);
            if (!v) throw Error("band closure: a fine point of a surface cell is missing from the map");
            (*v < 0.0f ? any_in : any_out) = true;
            if (any_in && any_out) return true;
        }
    return false;
}

}  // namespace

std::vector<CoarseCell> band_closure_cells(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                                           const FinePointMap& field) {
    const int cs = frame.coarse_steps;
    std::vector<std::uint64_t> present(cells.size());
    for (std::size_t i = 0; i < cells.size(); ++i) present[i] = lattice::pack(cells[i].coord);
    std::sort(present.begin(), present.end());
    const int max_coord = lattice::kMaxCoord / cs;

    std::vector<std::vector<CoarseCell>> found(cells.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 64), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
            for (int axis = 0; axis < 3; ++axis)
                for (int side = 0; side < 2; ++side) {
                    glm::ivec3 n = cells[i].coord;
                    n[axis] += side ? 1 : -1;
                    if (n[axis] >= 0 && n[axis] <= max_coord &&
                        std::binary_search(present.begin(), present.end(), lattice::pack(n)))
                        continue;
                    if (!face_is_crossed(cells[i], axis, side, cs, field)) continue;
                    if (n[axis] < 0 || n[axis] > max_coord)
                        throw Error("band closure: the surface leaves the reconstruction domain");
                    found[i].push_back({n, cells[i].level});
                }
    });

    std::vector<CoarseCell> out;
    for (const auto& f : found) out.insert(out.end(), f.begin(), f.end());
    std::sort(out.begin(), out.end(), [](const CoarseCell& x, const CoarseCell& y) {
        const auto kx = lattice::pack(x.coord), ky = lattice::pack(y.coord);
        return kx != ky ? kx < ky : x.level > y.level;  // largest level first per coordinate
    });
    out.erase(std::unique(out.begin(), out.end(),
                          [](const CoarseCell& x, const CoarseCell& y) { return x.coord == y.coord; }),
              out.end());
    return out;
}

}  // namespace trilevel
