// Transition continuity (paper §3.3.1, docs/design.md §7); see transition_continuity.hpp.
//
// As in the paper, only level-2 cells with a level-3 neighbour do work: across a face (the whole
// closed face) or across a coarse edge (that edge). Their level-2 values are gathered into a local
// block first; the midpoints of their uncrossed boundary edges are then looked up in one batch
// and overwritten.
#include "transition_continuity.hpp"

#include <atomic>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/cell_index.hpp"
#include "marching_cubes.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {
namespace {

struct Scratch {
    std::vector<std::uint64_t> keys;
    std::vector<glm::ivec3> points;  // local coordinates of the level-2 edge midpoints to set
    std::vector<float*> found;
    std::vector<float> level2;       // the cell's level-2 values, (cs/2+1)^3
};

class CellFixer {
public:
    CellFixer(const CellIndex& index, int cs, FinePointMap& field) : index_(index), cs_(cs), field_(field) {}
    void fix(const CoarseCell& cell, Scratch& s) const;

private:
    const CellIndex& index_;
    int cs_;
    FinePointMap& field_;

    bool level3(glm::ivec3 c) const { return index_.level(c) == 3; }
    void add_face(int axis, int side, Scratch& s) const;
    void add_edge(int axis, int sb, int sc, Scratch& s) const;
    float even_value(const Scratch& s, glm::ivec3 p) const {
        const int m = cs_ / 2 + 1;
        return s.level2[std::size_t(((p.z / 2) * m + p.y / 2) * m + p.x / 2)];
    }
    /// The values at the two ends of the level-2 edge whose midpoint is p (one odd coordinate).
    std::pair<float, float> ends(const Scratch& s, glm::ivec3 p) const {
        const glm::ivec3 e(p.x & 1, p.y & 1, p.z & 1);
        return {even_value(s, p - e), even_value(s, p + e)};
    }
};

// Midpoints of the level-2 edges of the closed face (axis, side), local coordinates: one of the
// two in-face coordinates odd. Face centres (both odd) keep their field values.
void CellFixer::add_face(int axis, int side, Scratch& s) const {
    const int b = (axis + 1) % 3, c = (axis + 2) % 3;
    for (int j = 0; j <= cs_; ++j)
        for (int i = 0; i <= cs_; ++i) {
            if (((i ^ j) & 1) == 0) continue;
            glm::ivec3 p{0};
            p[axis] = side * cs_;
            p[b] = i;
            p[c] = j;
            s.points.push_back(p);
        }
}

// Midpoints of the level-2 edges on the coarse edge along `axis` on sides sb (of axis+1) and sc (of axis+2).
void CellFixer::add_edge(int axis, int sb, int sc, Scratch& s) const {
    for (int i = 1; i < cs_; i += 2) {
        glm::ivec3 p{0};
        p[axis] = i;
        p[(axis + 1) % 3] = sb * cs_;
        p[(axis + 2) % 3] = sc * cs_;
        s.points.push_back(p);
    }
}

void CellFixer::fix(const CoarseCell& cell, Scratch& s) const {
    // Which face and edge neighbours are level 3, each looked up once (18 lookups, not 42).
    bool l3[3][3][3] = {};
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                const int nonzero = (dx != 0) + (dy != 0) + (dz != 0);
                if (nonzero == 1 || nonzero == 2) l3[dz + 1][dy + 1][dx + 1] = level3(cell.coord + glm::ivec3(dx, dy, dz));
            }
    auto at = [&](glm::ivec3 d) { return l3[d.z + 1][d.y + 1][d.x + 1]; };
    s.points.clear();
    for (int axis = 0; axis < 3; ++axis) {
        const int b = (axis + 1) % 3, c = (axis + 2) % 3;
        for (int side = 0; side < 2; ++side) {
            glm::ivec3 n(0);
            n[axis] = side ? 1 : -1;
            if (at(n)) add_face(axis, side, s);
        }
        for (int sb = 0; sb < 2; ++sb)
            for (int sc = 0; sc < 2; ++sc) {
                glm::ivec3 nb(0), nc(0);
                nb[b] = sb ? 1 : -1;
                nc[c] = sc ? 1 : -1;
                if (at(nb) || at(nc) || at(nb + nc)) add_edge(axis, sb, sc, s);
            }
    }
    if (s.points.empty()) return;
    find_level2_points(field_, cell.coord, cs_, s.keys, s.found);
    s.level2.resize(s.keys.size());
    for (std::size_t i = 0; i < s.keys.size(); ++i) {
        if (!s.found[i]) throw Error("transition continuity: level-2 lattice point missing from the fine point map");
        s.level2[i] = *s.found[i];
    }
    // A crossed edge keeps the field's (true) midpoint value: both sides read it alike.
    std::erase_if(s.points, [&](glm::ivec3 p) {
        const auto [va, vb] = ends(s, p);
        return mc::inside(va) != mc::inside(vb);
    });
    const glm::ivec3 base = cell.coord * cs_;
    s.keys.clear();
    for (const glm::ivec3& p : s.points) s.keys.push_back(lattice::pack(base + p));
    s.found.resize(s.keys.size());
    find_batch(field_, s.keys.data(), s.keys.size(), s.found.data());
    for (std::size_t i = 0; i < s.points.size(); ++i) {
        if (!s.found[i]) continue;
        const auto [va, vb] = ends(s, s.points[i]);
        // Cells sharing the point store the same value: relaxed atomics keep it race-free.
        std::atomic_ref<float>(*s.found[i]).store(lattice::edge_midpoint_value(va, vb), std::memory_order_relaxed);
    }
}

}  // namespace

void apply_transition_continuity(const std::vector<CoarseCell>& cells, const LatticeFrame& lattice_frame,
                                 FinePointMap& field) {
    apply_transition_continuity(cells, CellIndex(cells), lattice_frame, field);
}

void apply_transition_continuity(const std::vector<CoarseCell>& cells, const CellIndex& index,
                                 const LatticeFrame& lattice_frame, FinePointMap& field) {
    if (lattice_frame.coarse_steps % 2 != 0) throw Error("transition continuity: coarse_steps must be even");
    const CellFixer fixer(index, lattice_frame.coarse_steps, field);
    // The level-2 cells in the 3x3x3 blocks around the level-3 cells: only these can have a
    // level-3 neighbour across a face or an edge. Level 3 is a few percent of the cells (x64: 5 k of
    // 128 k), so 26 lookups per level-3 cell spare most level-2 cells the 18 of fix().
    std::vector<std::uint8_t> near_level3(cells.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 1024), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            if (cells[i].level != 3) continue;
            for (int dz = -1; dz <= 1; ++dz)
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const std::int64_t j = index.position(cells[i].coord + glm::ivec3(dx, dy, dz));
                        if (j >= 0) std::atomic_ref<std::uint8_t>(near_level3[std::size_t(j)]).store(1, std::memory_order_relaxed);
                    }
        }
    });
    tbb::enumerable_thread_specific<Scratch> scratch;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 256), [&](const auto& r) {
        Scratch& s = scratch.local();
        for (std::size_t i = r.begin(); i != r.end(); ++i)
            if (cells[i].level == 2 && near_level3[i]) fixer.fix(cells[i], s);
    });
}

}  // namespace trilevel
