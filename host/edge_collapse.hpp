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
    /// Runs work(i, worker) for items i = 0 .. n-1 on all threads, in slabs `width` wide by
    /// coordinate place(i) in [0, span] along one axis: the even slabs at once, then the odd ones,
    /// each slab's items in ascending order, each thread with a region's Worker. Two items in
    /// slabs of one parity lie a slab apart, so where `width` covers what an item reads and
    /// writes, the result does not depend on the threads. Returns, per item, whether work gave
    /// false (it left the rest for a serial pass, in item order, by the caller).
    template <class Place, class Work>
    std::vector<std::uint8_t> in_slabs(std::size_t n, double span, double width, Place&& place, Work&& work);

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

template <class Place, class Work>
std::vector<std::uint8_t> EdgeCollapser::in_slabs(std::size_t n, double span, double width, Place&& place, Work&& work) {
    const std::size_t slabs = std::size_t(std::min(std::floor(span / width), 1e6)) + 1;
    std::vector<std::vector<std::uint32_t>> in_slab(slabs);  // item numbers, ascending
    for (std::uint32_t i = 0; i < n; ++i) in_slab[std::min(slabs - 1, std::size_t(place(i) / width))].push_back(i);
    std::vector<std::uint8_t> deferred(n, 0);
    tbb::enumerable_thread_specific<Worker> workers([] {
        Worker w;
        w.parallel = true;
        return w;
    });
    for (std::size_t parity = 0; parity < 2; ++parity) {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, (slabs + 1 - parity) / 2, 1), [&](const auto& range) {
            Worker& w = workers.local();
            for (std::size_t k = range.begin(); k != range.end(); ++k)
                for (std::uint32_t i : in_slab[2 * k + parity]) deferred[i] = !work(i, w);
        });
        for (Worker& w : workers) adopt(w);
    }
    return deferred;
}

}  // namespace trilevel
