// Edge collapse by index on a closed oriented triangle mesh, restricted to a chosen set of vertices
// (crack closing, crack_collapse.hpp; sliver cleanup, sliver_cleanup.hpp): merging vertex v into a
// neighbour a removes the two triangles on edge (v, a), and v's other triangles take a instead.
// A collapse is made only where it keeps the mesh a closed oriented 2-manifold (link condition:
// v and a share no neighbour but the two apexes of the edge; no tetrahedron folded shut), turns
// no triangle over and moves none of v's triangles through another triangle (a new crossing with
// a triangle it shares no vertex with); otherwise nothing changes.
#pragma once

#include <cstddef>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include <glm/glm.hpp>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "triangle_grid.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {

/// The kept-vertex list of a mesh of n vertices that lost none: 0, 1, ..., n - 1.
std::vector<std::uint32_t> every_vertex(std::size_t n);

/// Per-vertex values carried over a collapse: the value of each vertex left, from `values` per
/// old vertex and the collapse's kept-vertex list (old index of each vertex left).
template <class T>
std::vector<T> kept_values(const std::vector<T>& values, const std::vector<std::uint32_t>& kept) {
    std::vector<T> out(kept.size());
    for (std::size_t v = 0; v < kept.size(); ++v) out[v] = values[kept[v]];
    return out;
}

class EdgeCollapser {
public:
    /// `vertices`: every vertex that collapse() may be given (as v or a); only those get triangle
    /// lists, so one pass over the triangles is all the mesh-wide work. Duplicates are fine.
    EdgeCollapser(Mesh& mesh, const std::vector<std::uint32_t>& vertices);
    /// Merges vertex v into its neighbour a (a keeps its position); false (nothing changed) where
    /// that is not safe or (v, a) is no edge (any more).
    bool collapse(std::uint32_t v, std::uint32_t a) { return collapse(v, a, main_) == Outcome::Collapsed; }
    /// Drops the dead vertices and triangles, keeping the order of the rest (positions, levels,
    /// triangle kinds; the mesh has no normals or attributes yet). Returns the old index of each
    /// vertex left, ascending (every vertex, and nothing to drop, where no collapse was made).
    std::vector<std::uint32_t> compact();
    glm::dvec3 position(std::uint32_t v) const {
        return {m_.positions[3 * v], m_.positions[3 * v + 1], m_.positions[3 * v + 2]};
    }
    bool dead(std::uint32_t v) const { return dead_vertex_[v] != 0; }
    std::size_t collapses() const { return collapses_; }  ///< made so far

    // Collapses on several threads at once, each in its own region (sliver_cleanup.cpp). Where no
    // triangle is larger than interaction_reach() along any axis, a collapse reads only triangles
    // within 3 and writes only triangles within 2 interaction reaches of v along every axis; a
    // Worker's collapse that would make a triangle larger is deferred instead.
    struct Worker;
    enum class Outcome { Collapsed, Refused, Deferred };
    /// Widens the crossing check's queries to triangles `growth` times the largest now (moved
    /// triangles grow a little). Needs listed vertices (the index is made with their lists).
    void prepare_parallel(double growth);
    /// The index's cell side and the triangles' bound, whichever is larger; prepare_parallel() first.
    double interaction_reach() const { return std::max(grid_->cell_side(), bound_); }
    Outcome collapse(std::uint32_t v, std::uint32_t a, Worker& w);
    /// Moves the triangles a worker relisted into the index's own lists (between parallel phases).
    void adopt(Worker& w);
    /// Runs work(i, worker) for items i = 0 .. n-1 on all threads, in square tiles `width` wide
    /// across the two longest axes of the box around the items' points position(i): four phases,
    /// one per parity of the tile's column and row, each phase's tiles at once, a tile's items in
    /// ascending order, each thread with a region's Worker. Two tiles of one phase lie a tile apart
    /// along one axis at least, so where `width` covers what an item reads and writes along every
    /// axis, the result does not depend on the threads. (Slabs across one axis, two phases, left
    /// a frame's few heavy slabs to one thread each.) Returns, per item, whether work gave false
    /// (it left the rest for a serial pass, in item order, by the caller).
    template <class Position, class Work>
    std::vector<std::uint8_t> in_tiles(std::size_t n, double width, Position&& position, Work&& work);

    /// collapse()'s scratch and, for a region's worker, the triangles it relisted (triangle_grid.hpp).
    struct MovedTriangle {  // makes_crossing()'s scratch: corners after, positions before and after, box after, normals
        std::uint32_t after[3];
        glm::dvec3 p[3], q[3], lo, hi, np, nq;
    };
    struct Worker {
        bool parallel = false;  ///< a region's worker: its relists are its own, growth is deferred
        std::vector<std::uint32_t> edge, rest, nv, na;
        std::vector<MovedTriangle> moved;
        std::vector<std::uint32_t> near;
        TriangleGrid::Local relisted;
    };

private:
    Mesh& m_;
    std::vector<std::int32_t> list_;                 // vertex -> its triangle list, -1: not listed
    std::vector<std::vector<std::uint32_t>> tris_;   // triangles around each listed vertex (dead ones pruned lazily)
    std::vector<std::uint8_t> dead_tri_, dead_vertex_;
    std::atomic<std::size_t> collapses_{0};  // made so far (Workers count theirs at once)
    Worker main_;                        // collapse()'s, single-threaded
    double bound_ = 0.0;                 // a Worker's moved triangles' largest extent
    std::optional<TriangleGrid> grid_;  // the crossing check's, made with the lists

    void list_triangles(const std::vector<std::uint32_t>& vertices);  // tris_ of `vertices`
    std::uint32_t* corners(std::uint32_t t) { return m_.triangles.data() + 3 * std::size_t(t); }
    std::vector<std::uint32_t>& alive_triangles(std::uint32_t v);
    bool flips(std::uint32_t t, std::uint32_t v, glm::dvec3 to);
    // Would moving v onto a make one of `moved` (v's triangles off edge (v, a)) cross a triangle it
    // crossed nowhere before and shares no vertex with? Leaves the moved triangles in w.moved.
    bool makes_crossing(std::uint32_t v, std::uint32_t a, const std::vector<std::uint32_t>& moved, Worker& w);
};

template <class Position, class Work>
std::vector<std::uint8_t> EdgeCollapser::in_tiles(std::size_t n, double width, Position&& position, Work&& work) {
    std::vector<std::uint8_t> deferred(n, 0);
    if (n == 0) return deferred;
    glm::dvec3 lo = position(0), hi = lo;
    for (std::uint32_t i = 1; i < n; ++i) {
        const glm::dvec3 p = position(i);
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    const glm::dvec3 size = hi - lo;
    const int u = size.x >= size.y && size.x >= size.z ? 0 : size.y >= size.z ? 1 : 2;  // the longest axis
    const int v = u == 0 ? (size.y >= size.z ? 1 : 2) : u == 1 ? (size.x >= size.z ? 0 : 2) : (size.x >= size.y ? 0 : 1);
    constexpr std::uint64_t kLast = (1u << 21) - 1;  // tiles per axis, at most (a key's 21 bits)
    auto tile = [&](double x) {
        const double t = width > 0.0 ? std::floor(x / width) : 0.0;
        return t >= double(kLast) ? kLast : std::uint64_t(t);
    };
    // Each item's key: phase (2 bits), row, column; sorted by key, then item.
    std::vector<std::pair<std::uint64_t, std::uint32_t>> order(n);
    for (std::uint32_t i = 0; i < n; ++i) {
        const glm::dvec3 p = position(i) - lo;
        const std::uint64_t col = tile(p[u]), row = tile(p[v]);
        order[i] = {((col & 1) | (row & 1) << 1) << 42 | row << 21 | col, i};
    }
    std::sort(order.begin(), order.end());
    std::vector<std::size_t> first;  // where each tile's items begin in `order`, and n
    for (std::size_t k = 0; k < n; ++k)
        if (k == 0 || order[k].first != order[k - 1].first) first.push_back(k);
    first.push_back(n);
    tbb::enumerable_thread_specific<Worker> workers([] {
        Worker w;
        w.parallel = true;
        return w;
    });
    for (std::size_t b = 0; b + 1 < first.size();) {  // phase by phase: tiles b .. e - 1
        const std::uint64_t phase = order[first[b]].first >> 42;
        std::size_t e = b + 1;
        while (e + 1 < first.size() && order[first[e]].first >> 42 == phase) ++e;
        tbb::parallel_for(tbb::blocked_range<std::size_t>(b, e, 1), [&](const auto& range) {
            Worker& w = workers.local();
            for (std::size_t t = range.begin(); t != range.end(); ++t)
                for (std::size_t k = first[t]; k < first[t + 1]; ++k) deferred[order[k].second] = !work(order[k].second, w);
        });
        for (Worker& w : workers) adopt(w);
        b = e;
    }
    return deferred;
}

}  // namespace trilevel
