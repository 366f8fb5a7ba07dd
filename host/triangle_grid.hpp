// The triangles of a mesh in a uniform grid, for "which triangles can touch this box?" queries
// while the mesh changes (edge_collapse.hpp's crossing check). Each triangle is listed once, in
// the cell of its bounding box's low corner; with cells at least as large as every triangle, the
// triangles overlapping a box lie in the cells from the box's low corner less one triangle extent
// to its high corner: 3 x 3 x 3 cells for a box of one cell. The cells are dense and in x-rows,
// so such a query reads 9 contiguous runs of entries, each entry's box beside it. Where the grid
// over the mesh's box would have too many cells, the cells grow a little, then the grid wraps
// around (cell coordinates modulo the grid's size along each axis: cells far apart share a slot,
// whose extra entries the box test skips). Cells grown without bound made every query of a
// splayed mesh read most of it: two clusters 40 units apart took 127 s in the sliver cleanup,
// each alone 0.5 s.
//
// Triangles whose corners change are listed again in per-cell lists: the grid's own, or a
// Local's, where several threads move triangles at once in regions far apart (each query then
// sees the grid's lists and its own thread's); adopt() moves a Local's into the grid's. Both are
// kept by a hash of the cells that hold any, not an array over the grid (two more words a cell,
// 10 MB at x64, for the few cells a collapse touches). Every query runs with a Local, its own
// thread's (also its scratch).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "trilevel/trilevel.hpp"

namespace trilevel {

class TriangleGrid {
public:
    /// Lists every triangle t of `mesh` with dead[t] == 0 by its box now.
    TriangleGrid(const Mesh& mesh, const std::vector<std::uint8_t>& dead);

    /// One thread's relisted triangles while others relist theirs (see above), and its queries' scratch.
    class Local {
    public:
        Local() = default;

    private:
        friend class TriangleGrid;
        // Per cell that holds any: its newest entry. A hash of the cells (open addressing, linear
        // probing, load 1/2 at most) rather than an array over the grid, which every thread's
        // Local would hold (megabytes each on a large frame) for a few thousand entries.
        std::vector<std::uint32_t> cells_, heads_;  // cell + 1 (0: a free slot), its newest entry
        std::size_t used_ = 0;
        std::uint32_t head(std::size_t cell) const {
            if (used_ == 0) return ~0u;
            for (std::size_t s = slot_of(cell);; s = (s + 1) & (cells_.size() - 1)) {
                if (cells_[s] == 0) return ~0u;
                if (cells_[s] == cell + 1) return heads_[s];
            }
        }
        void set_head(std::size_t cell, std::uint32_t entry);
        std::size_t slot_of(std::size_t cell) const { return (cell * 0x9E3779B97F4A7C15ull >> 20) & (cells_.size() - 1); }
        std::vector<std::uint32_t> next_, tri_, cell_;  // entries, oldest first
        std::vector<glm::vec3> lo_, hi_;                // each entry's box when it was listed
        std::vector<std::uint32_t> reported_;         // a query's relisted triangles, reported once
    };

    /// Lists triangle t again by its new box lo..hi (its corners changed), in the grid's lists or
    /// in `local`'s; its older entries are ignored from now on.
    void relist(std::uint32_t t, glm::dvec3 lo, glm::dvec3 hi, Local* local = nullptr);

    /// Moves `local`'s entries into the grid's lists, in their order, and empties it.
    void adopt(Local& local);

    /// Calls visit(t) once for each listed triangle whose box at one of its listings overlaps the
    /// box lo..hi: every one whose box now does (its latest listing's), and some that no longer do
    /// (the caller tests its corners). Boxes are tested before a triangle is touched, so that a
    /// query never reads a triangle in a slot it shares with cells far away, which another thread
    /// may be moving. `local`: the calling thread's.
    template <class Visit>
    void for_each_near(glm::dvec3 lo, glm::dvec3 hi, Local& local, Visit&& visit);

    /// The largest extent of a listed triangle: a box's queries reach this far below its low corner.
    double reach() const { return reach_; }
    /// Queries reach at least r below a box from now on (triangles relisted in a Local may grow
    /// up to r).
    void widen_reach(double r) { reach_ = std::max(reach_, r); }
    /// The cells' side (at least reach()).
    double cell_side() const { return cell_; }

private:
    double cell_ = 1.0, reach_ = 0.0;  // cell side; the largest triangle extent (a relisted one's too)
    glm::dvec3 origin_{0.0};
    glm::ivec3 dims_{1};
    // Triangles by cell in x-rows: cell c's entries are entry_[start_[c] .. start_[c + 1]), with
    // their boxes (floats hold the float positions' bounds exactly).
    std::vector<std::uint32_t> start_, entry_;
    std::vector<glm::vec3> entry_lo_, entry_hi_;
    // Relisted triangles: a linked list per cell (the grid's own Local), and a count per x-row so
    // that rows without any are skipped.
    Local moved_;
    std::vector<std::uint32_t> moved_in_row_;
    std::vector<std::uint8_t> relisted_;  // per triangle: its first entry is stale

    /// The cell of p before wrapping, and the slot it wraps to.
    glm::i64vec3 raw_cell(glm::dvec3 p) const;
    glm::ivec3 cell(glm::dvec3 p) const { return wrap(raw_cell(p)); }
    glm::ivec3 wrap(glm::i64vec3 c) const;
    std::size_t index(int x, int y, int z) const { return (std::size_t(z) * std::size_t(dims_.y) + std::size_t(y)) * std::size_t(dims_.x) + std::size_t(x); }
    void relist_in_grid(std::uint32_t t, std::size_t c, glm::vec3 lo, glm::vec3 hi);
    static void push(Local& list, std::uint32_t t, std::size_t c, glm::vec3 lo, glm::vec3 hi);
};

template <class Visit>
void TriangleGrid::for_each_near(glm::dvec3 lo, glm::dvec3 hi, Local& local, Visit&& visit) {
    // A relisted triangle (listed again each time it moves) is reported once: a query meets a handful.
    local.reported_.clear();
    const glm::vec3 lof(lo), hif(hi);  // a float box holds the float corners' box
    auto report = [&](const Local& list, std::uint32_t k) {
        if (glm::any(glm::lessThan(list.hi_[k], lof)) || glm::any(glm::greaterThan(list.lo_[k], hif))) return;
        const std::uint32_t t = list.tri_[k];
        for (std::uint32_t u : local.reported_)
            if (u == t) return;
        local.reported_.push_back(t);
        visit(t);
    };
    const glm::i64vec3 r0 = raw_cell(lo - reach_), r1 = raw_cell(hi);
    // The cells' slots: each slot once (a box wider than the grid takes every slot of that axis);
    // along x one run of slots, or two where it wraps.
    const glm::i64vec3 span = glm::min(r1 - r0 + std::int64_t(1), glm::i64vec3(dims_));
    const glm::ivec3 w0 = wrap(r0);
    const int x_first_end = int(std::min<std::int64_t>(dims_.x, w0.x + span.x));
    const int x_wrapped_end = int(w0.x + span.x - x_first_end);  // slots 0 .. this - 1 after the wrap
    for (std::int64_t dz = 0; dz < span.z; ++dz)
        for (std::int64_t dy = 0; dy < span.y; ++dy) {
            const int z = int((w0.z + dz) % dims_.z), y = int((w0.y + dy) % dims_.y);
            const std::size_t row = index(0, y, z);
            for (const auto& [from, to] : {std::pair{w0.x, x_first_end}, std::pair{0, x_wrapped_end}}) {
                if (from >= to) continue;
                for (std::uint32_t i = start_[row + std::size_t(from)], e = start_[row + std::size_t(to)]; i < e; ++i) {
                    if (glm::any(glm::lessThan(entry_hi_[i], lof)) || glm::any(glm::greaterThan(entry_lo_[i], hif))) continue;
                    const std::uint32_t t = entry_[i];
                    if (!relisted_[t]) visit(t);
                }
                if (moved_in_row_[std::size_t(z) * std::size_t(dims_.y) + std::size_t(y)] != 0)
                    for (int x = from; x < to; ++x)
                        for (std::uint32_t k = moved_.head(row + std::size_t(x)); k != ~0u; k = moved_.next_[k]) report(moved_, k);
                if (local.used_ != 0)
                    for (int x = from; x < to; ++x)
                        for (std::uint32_t k = local.head(row + std::size_t(x)); k != ~0u; k = local.next_[k]) report(local, k);
            }
        }
}

}  // namespace trilevel
