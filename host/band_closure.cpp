// Band closure (docs/design.md §7); see band_closure.hpp.
#include "band_closure.hpp"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/cell_index.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {
namespace {

struct Scratch {
    std::vector<std::uint64_t> keys;
    std::vector<const float*> found;
};

// The faces of `cell` with no neighbour in the set, and for each whether it holds both signs
// (points at the cell's stride, values after continuity). All their points in one batched lookup.
class FaceChecker {
public:
    FaceChecker(const CellIndex& index, int cs, const FinePointMap& field) : index_(index), cs_(cs), field_(field) {}

    void check(const CoarseCell& cell, Scratch& s, std::vector<CoarseCell>& out) const {
        int open[6], n_open = 0;
        for (int f = 0; f < 6; ++f)
            if (index_.level(neighbour(cell, f)) == 0) open[n_open++] = f;
        if (n_open == 0) return;
        s.keys.clear();
        for (int k = 0; k < n_open; ++k) add_face_keys(cell, open[k], s.keys);
        s.found.resize(s.keys.size());
        find_batch(field_, s.keys.data(), s.keys.size(), s.found.data());
        const std::size_t per_face = s.keys.size() / std::size_t(n_open);
        for (int k = 0; k < n_open; ++k) {
            bool any_in = false, any_out = false;
            for (std::size_t i = k * per_face; i < (k + 1) * per_face; ++i) {
                if (!s.found[i]) throw Error("band closure: a fine point of a surface cell is missing from the map");
                (*s.found[i] < 0.0f ? any_in : any_out) = true;
            }
            if (!(any_in && any_out)) continue;
            const glm::ivec3 n = neighbour(cell, open[k]);
            // The cell's last lattice point (n + 1) * cs must still fit lattice::kMaxCoord.
            const glm::ivec3 last_cell(lattice::kMaxCoord / cs_ - 1);
            if (glm::any(glm::lessThan(n, glm::ivec3(0))) || glm::any(glm::greaterThan(n, last_cell)))
                throw Error("band closure: the surface leaves the reconstruction domain");
            out.push_back({n, cell.level});
        }
    }

private:
    const CellIndex& index_;
    int cs_;
    const FinePointMap& field_;

    static glm::ivec3 neighbour(const CoarseCell& cell, int face) {
        glm::ivec3 n = cell.coord;
        n[face / 2] += (face & 1) ? 1 : -1;
        return n;
    }
    void add_face_keys(const CoarseCell& cell, int face, std::vector<std::uint64_t>& keys) const {
        const int axis = face / 2, b = (axis + 1) % 3, c = (axis + 2) % 3, st = stride(cell.level);
        for (int j = 0; j <= cs_; j += st)
            for (int i = 0; i <= cs_; i += st) {
                glm::ivec3 p = cell.coord * cs_;
                p[axis] += (face & 1) * cs_;
                p[b] += i;
                p[c] += j;
                keys.push_back(lattice::pack(p));
            }
    }
};

bool by_key_then_level_down(const CoarseCell& x, const CoarseCell& y) {
    const auto kx = lattice::pack(x.coord), ky = lattice::pack(y.coord);
    return kx != ky ? kx < ky : x.level > y.level;
}

}  // namespace

std::vector<CoarseCell> band_closure_cells(const std::vector<CoarseCell>& cells, const LatticeFrame& lattice_frame,
                                           const FinePointMap& field) {
    return band_closure_cells(cells, CellIndex(cells), lattice_frame, field);
}

std::vector<CoarseCell> band_closure_cells(const std::vector<CoarseCell>& cells, const CellIndex& index,
                                           const LatticeFrame& lattice_frame, const FinePointMap& field) {
    const int cs = lattice_frame.coarse_steps;
    const FaceChecker checker(index, cs, field);
    tbb::enumerable_thread_specific<Scratch> scratch;
    std::vector<std::vector<CoarseCell>> found(cells.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 64), [&](const auto& r) {
        Scratch& s = scratch.local();
        for (std::size_t i = r.begin(); i != r.end(); ++i) checker.check(cells[i], s, found[i]);
    });

    std::vector<CoarseCell> out;
    for (const auto& f : found) out.insert(out.end(), f.begin(), f.end());
    std::sort(out.begin(), out.end(), by_key_then_level_down);  // largest level first per coordinate
    out.erase(std::unique(out.begin(), out.end(),
                          [](const CoarseCell& x, const CoarseCell& y) { return x.coord == y.coord; }),
              out.end());
    return out;
}

}  // namespace trilevel
