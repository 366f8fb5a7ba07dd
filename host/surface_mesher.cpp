// Triangulation of the coarse surface cells (paper §3.3, docs/design.md §6-7); see surface_mesher.hpp.
//
// Phase 1, parallel over fixed chunks of cells: gather each cell's (n+1)^3 values, run marching
// cubes with cell-local vertex slots, stitch its transition faces (level-3 side). Phase 2: number
// the vertices in stream order; only those on a cell boundary go through a hash. On few threads
// it runs in chunk order while later chunks are still meshed (a TBB pipeline), on many after
// phase 1 on all threads. Phase 3, parallel: rewrite triangle indices.
#include "surface_mesher.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <type_traits>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include "core/cell_index.hpp"
#include "core/run_beside.hpp"
#include "crack_collapse.hpp"
#include "crack_stitch.hpp"
#include "marching_cubes.hpp"

namespace trilevel {
namespace {

constexpr std::size_t kCellsPerChunk = 64;  // fixed, so chunking never depends on the thread count
// From this many threads on, phase 2 runs on all threads after phase 1 (number_vertices), below it
// beside phase 1 on one (number_chunk); both give the same numbers.
constexpr int kNumberingThreads = 8;

struct ChunkOut {
    std::vector<std::uint64_t> keys;   // per chunk-local vertex: edge key
    std::vector<glm::vec3> positions;
    std::vector<std::uint8_t> level;
    std::vector<std::uint8_t> shared;  // on a cell boundary: may repeat in other cells (2: a repeat, while numbering)
    std::vector<std::uint32_t> triangles;
    std::vector<TriangleKind> kinds;
    std::vector<std::uint32_t> crack_runs;  // host/crack_collapse.hpp, chunk-local vertex ids
};

struct Scratch {
    std::vector<float> values;
    std::vector<std::int32_t> slots;
    std::vector<std::pair<std::uint64_t, std::uint64_t>> home;  // stored key, home slot
    std::vector<float> midpoint;          // level 2: midpoint value per crossed edge (point * 3 + axis)
    std::vector<std::uint64_t> mid_keys;  // level 2: the crossed edges' midpoint keys ...
    std::vector<int> mid_edges;           // ... their edge slots
    std::vector<const float*> mid_found;
};

// The crossing on the unit edge from `lower` along `axis` with end values va, vb (docs/design.md §7);
// both sides of a transition face call it with identical arguments. origin + step * (lower + t)
// in double (exact but for the last bits of a double), rounded once to float: in float, lower + t
// alone would keep t only to 2^-6 of a step at lattice coordinate 2^17.
//
// The crossing stays strictly inside its edge in float: one that rounds onto an end (t within a
// float step of 0 or 1, likely far from the origin, or a value exactly 0) takes the nearest float
// inside instead. Otherwise the crossings of the other edges at that end could round onto the
// same point: distinct vertices at one position, degenerate triangles, and a mesh that is closed
// by index but not once coincident vertices are welded (frame 23 moved 3e3 units away: 29 such
// vertices, 5 non-manifold edges after welding).
glm::vec3 crossing_position(const LatticeFrame& f, glm::ivec3 lower, int axis, float va, float vb) {
    const float t = va / (va - vb);
    glm::vec3 p;
    for (int k = 0; k < 3; ++k) {
        const double q = double(lower[k]) + (k == axis ? double(t) : 0.0);
        p[k] = float(double(f.origin[k]) + double(f.step) * q);
    }
    const float end0 = float(double(f.origin[axis]) + double(f.step) * double(lower[axis]));
    const float end1 = float(double(f.origin[axis]) + double(f.step) * (double(lower[axis]) + 1.0));
    if (p[axis] <= end0) p[axis] = std::nextafter(end0, end1);
    else if (p[axis] >= end1) p[axis] = std::nextafter(end1, end0);
    return p;
}

class CellMesher {
public:
    CellMesher(const LatticeFrame& lattice_frame, const FinePointMap& field, const CellIndex& cells)
        : lattice_frame_(lattice_frame), field_(field), cells_(cells) {}

    void mesh(const CoarseCell& cell, Scratch& s, ChunkOut& out) const;

private:
    const LatticeFrame& lattice_frame_;
    const FinePointMap& field_;
    const CellIndex& cells_;
    bool gather(const CoarseCell& cell, int n, Scratch& s) const;
    void stitch(const CoarseCell& cell, Scratch& s, ChunkOut& out) const;
    void level2_midpoints(const CoarseCell& cell, int n, Scratch& s) const;
};

// Two passes so the (cache-missing) hash probes of a cell overlap: prefetch every home slot, then
// probe. Returns false when all values have one sign: no crossing in the cell or on its faces.
bool CellMesher::gather(const CoarseCell& cell, int n, Scratch& s) const {
    const int st = stride(cell.level), np = n + 1;
    const glm::ivec3 base = cell.coord * lattice_frame_.coarse_steps;
    const std::size_t count = std::size_t(np) * np * np;
    const float* values = field_.values().data();
    const std::uint64_t capacity = field_.capacity();
    const lattice::KeyLayout& layout = field_.layout();
    s.values.resize(count);
    s.home.resize(count);
    std::size_t inside = 0;
    field_.with_keys([&](const auto* keys) {
        using Key = std::remove_cvref_t<decltype(*keys)>;
        std::size_t i = 0;
        for (int z = 0; z < np; ++z)
            for (int y = 0; y < np; ++y)
                for (int x = 0; x < np; ++x, ++i) {  // home slot by the packed key, compare the stored one
                    const glm::ivec3 p = base + st * glm::ivec3(x, y, z);
                    s.home[i] = {layout.compact(p), lattice::home_slot(lattice::pack(p), capacity)};
                    __builtin_prefetch(keys + s.home[i].second);
                    __builtin_prefetch(values + s.home[i].second);
                }
        for (i = 0; i < count; ++i) {
            const Key key = Key(s.home[i].first);
            std::uint64_t slot = s.home[i].second;
            while (keys[slot] != key) {
                if (keys[slot] == Key(layout.empty()))
                    throw Error("triangulation: a fine point of a surface cell is missing from the map");
                slot = lattice::next_slot(slot, capacity);
            }
            s.values[i] = values[slot];
            inside += mc::inside(values[slot]);
        }
    });
    if (inside == 0 || inside == count) return false;
    s.slots.assign(count * 3, -1);
    return true;
}

// Midpoint values of the crossed level-2 edges of a cell by the level-2 midpoint rule (tests/reference/edge_refinement.hpp)
// (stored value when present, else the linear mean), looked up in one prefetched batch.
void CellMesher::level2_midpoints(const CoarseCell& cell, int n, Scratch& s) const {
    const int np = n + 1, axis_step[3] = {1, np, np * np};
    const glm::ivec3 base = cell.coord * lattice_frame_.coarse_steps;
    s.mid_keys.clear();
    s.mid_edges.clear();
    for (int z = 0, lp = 0; z < np; ++z)
        for (int y = 0; y < np; ++y)
            for (int x = 0; x < np; ++x, ++lp)
                for (int axis = 0; axis < 3; ++axis) {
                    const glm::ivec3 p(x, y, z);
                    if (p[axis] == n || mc::inside(s.values[lp]) == mc::inside(s.values[lp + axis_step[axis]])) continue;
                    glm::ivec3 mid = base + 2 * p;
                    mid[axis] += 1;
                    s.mid_keys.push_back(lattice::pack(mid));
                    s.mid_edges.push_back(lp * 3 + axis);
                }
    s.mid_found.resize(s.mid_keys.size());
    find_batch(field_, s.mid_keys.data(), s.mid_keys.size(), s.mid_found.data());
    s.midpoint.resize(s.values.size() * 3);
    for (std::size_t i = 0; i < s.mid_edges.size(); ++i) {
        const int e = s.mid_edges[i], lp = e / 3;
        const float va = s.values[lp], vb = s.values[lp + axis_step[e % 3]];
        s.midpoint[e] = s.mid_found[i] ? *s.mid_found[i] : lattice::edge_midpoint_value(va, vb);
    }
}

void CellMesher::mesh(const CoarseCell& cell, Scratch& s, ChunkOut& out) const {
    const bool l2 = cell.level == 2;
    const int st = stride(cell.level), n = lattice_frame_.coarse_steps / st, np = n + 1;
    const glm::ivec3 base = cell.coord * lattice_frame_.coarse_steps;
    if (!gather(cell, n, s)) return;
    if (l2) level2_midpoints(cell, n, s);
    const auto& table = mc::case_table();
    const auto& edges = mc::cube_edges();
    const int axis_step[3] = {1, np, np * np};
    int corner_off[8];
    for (int c = 0; c < 8; ++c) corner_off[c] = (c & 1) + ((c >> 1) & 1) * np + ((c >> 2) & 1) * np * np;
    const TriangleKind kind = l2 ? TriangleKind::Level2 : TriangleKind::Level3;

    // Vertex of cube edge e of the cube at local (x, y, z), created on first use. A level-2 edge
    // holds at most one crossing, so its slot is the edge's; the vertex lies on the unit sub-edge
    // whose end signs differ, the midpoint valued by the level-2 midpoint rule (docs/design.md §7,
    // tests/reference/edge_refinement.hpp): the same key and position from every cell sharing the edge.
    auto vertex = [&](int e, glm::ivec3 cube, int id0) -> std::uint32_t {
        const mc::CubeEdge& ce = edges[e];
        const int lp = id0 + corner_off[ce.corner0];
        std::int32_t& id = s.slots[lp * 3 + ce.axis];
        if (id >= 0) return std::uint32_t(id);
        float a0 = s.values[lp], a1 = s.values[lp + axis_step[ce.axis]];
        glm::ivec3 lower = cube + glm::ivec3(ce.corner0 & 1, (ce.corner0 >> 1) & 1, (ce.corner0 >> 2) & 1);
        const int b = (ce.axis + 1) % 3, c = (ce.axis + 2) % 3;
        const bool on_boundary = lower[b] == 0 || lower[b] == n || lower[c] == 0 || lower[c] == n;
        lower = base + st * lower;
        if (l2) {
            const float m = s.midpoint[lp * 3 + ce.axis];
            if (mc::inside(a0) != mc::inside(m)) a1 = m;
            else a0 = m, lower[ce.axis] += 1;
        }
        id = std::int32_t(out.keys.size());
        out.keys.push_back(lattice::edge_key(lower, ce.axis));
        out.positions.push_back(crossing_position(lattice_frame_, lower, ce.axis, a0, a1));
        out.level.push_back(std::uint8_t(cell.level));
        out.shared.push_back(on_boundary);
        return std::uint32_t(id);
    };

    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                const int id0 = (z * np + y) * np + x;
                float v[8];
                for (int c = 0; c < 8; ++c) v[c] = s.values[id0 + corner_off[c]];
                const mc::CubeCase& cc = table[mc::case_index(v)];
                for (int t = 0; t < cc.triangle_count; ++t) {
                    for (int k = 0; k < 3; ++k) out.triangles.push_back(vertex(cc.triangles[t][k], {x, y, z}, id0));
                    out.kinds.push_back(kind);
                }
            }
    if (!l2) stitch(cell, s, out);
}

// Crack patches on the faces this level-3 cell shares with level-2 cells (docs/design.md §7).
void CellMesher::stitch(const CoarseCell& cell, Scratch& s, ChunkOut& out) const {
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side) {
            glm::ivec3 nb = cell.coord;
            nb[axis] += side ? 1 : -1;
            if (cells_.level(nb) != 2) continue;
            const Level3Block block{cell.coord * lattice_frame_.coarse_steps, lattice_frame_.coarse_steps,
                                    s.values.data(), s.slots.data(), out.positions.data()};
            const std::size_t patches = stitch_transition_face(block, axis, side, field_, out.triangles, out.crack_runs);
            out.kinds.insert(out.kinds.end(), patches, TriangleKind::Patch);
        }
}

// Frees a vector's storage (`v = {}` would keep its capacity: it assigns an empty list).
template <class T>
void release(std::vector<T>& v) {
    std::vector<T>().swap(v);
}

// Frees a numbered chunk's vertices: what phase 3 does not read.
void release_vertices(ChunkOut& c) {
    release(c.keys);
    release(c.positions);
    release(c.level);
    release(c.shared);
}

// Edge key -> global vertex index, open addressing with linear probing; grows at load 1/2.
class VertexIndex {
public:
    explicit VertexIndex(std::size_t expected) { reset(expected); }
    // Brings the home slot of `key` into the cache ahead of get_or_insert.
    void prefetch(std::uint64_t key) const { __builtin_prefetch(&table_[lattice::hash(key) & mask_]); }
    // Returns the index stored for `key`, inserting `fresh` when absent.
    std::uint32_t get_or_insert(std::uint64_t key, std::uint32_t fresh, bool& inserted) {
        if (2 * (size_ + 1) > table_.size()) grow();
        std::uint64_t s = lattice::hash(key) & mask_;
        for (; table_[s].key != lattice::kEmptyKey; s = (s + 1) & mask_)
            if (table_[s].key == key) return inserted = false, table_[s].id;
        table_[s] = {key, fresh};
        ++size_;
        inserted = true;
        return fresh;
    }

private:
    struct Entry {
        std::uint64_t key;
        std::uint32_t id;
    };
    std::vector<Entry> table_;
    std::size_t size_ = 0;
    std::uint64_t mask_ = 0;

    void reset(std::size_t expected) {
        std::size_t c = 1024;
        while (c < 2 * expected) c *= 2;
        table_.assign(c, Entry{lattice::kEmptyKey, 0});
        mask_ = c - 1;
        size_ = 0;
    }
    void grow() {
        std::vector<Entry> old;
        old.swap(table_);
        reset(old.size());
        for (const Entry& e : old) {
            if (e.key == lattice::kEmptyKey) continue;
            std::uint64_t s = lattice::hash(e.key) & mask_;
            while (table_[s].key != lattice::kEmptyKey) s = (s + 1) & mask_;
            table_[s] = e;
            ++size_;
        }
    }
};

// Phase 2 on few threads, in chunk order while later chunks are still meshed: numbers vertices by
// first appearance in the canonical stream (docs/design.md §6); only vertices on a cell boundary
// can repeat, so only they go through the index. A vertex made by any level-2 cube is level 2.
void number_chunk(ChunkOut& c, VertexIndex& index, std::vector<std::uint32_t>& ids, Mesh& mesh) {
    ids.resize(c.keys.size());
    // This filter is the pipeline's serial part (at 16 threads the meshing keeps up with it): the
    // probes' cache misses overlap (bench/RESULTS-implementation.md).
    for (std::size_t v = 0; v < c.keys.size(); ++v)
        if (c.shared[v]) index.prefetch(c.keys[v]);
    for (std::size_t v = 0; v < c.keys.size(); ++v) {
        bool fresh = true;
        const std::uint32_t next = std::uint32_t(mesh.vertex_level.size());
        const std::uint32_t id = c.shared[v] ? index.get_or_insert(c.keys[v], next, fresh) : next;
        if (fresh) {
            mesh.positions.insert(mesh.positions.end(), {c.positions[v].x, c.positions[v].y, c.positions[v].z});
            mesh.vertex_level.push_back(c.level[v]);
        } else {
            mesh.vertex_level[id] = std::min(mesh.vertex_level[id], c.level[v]);
        }
        ids[v] = id;
    }
    release_vertices(c);
}

// The vertices on cell boundaries, which several cells make, by edge key: where each first
// appears in the canonical stream (chunk, then chunk-local vertex), the lowest level it is made
// on, and its global index. Filled by many threads at once (open addressing, linear probing,
// claimed by compare-and-swap); sized once, at load 1/2 at most.
class SharedVertices {
public:
    explicit SharedVertices(std::size_t count) {
        std::size_t c = 1024;
        while (c < 2 * count) c *= 2;
        mask_ = c - 1;
        keys_ = std::make_unique<std::atomic<std::uint64_t>[]>(c);
        first_ = std::make_unique<std::atomic<std::uint64_t>[]>(c);
        level_ = std::make_unique<std::atomic<std::uint8_t>[]>(c);
        id_.resize(c);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, c, 65536), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
                keys_[i].store(lattice::kEmptyKey, std::memory_order_relaxed);
                first_[i].store(~std::uint64_t(0), std::memory_order_relaxed);
                level_[i].store(0xff, std::memory_order_relaxed);
            }
        });
    }
    // Adds one appearance (its stream position and level); returns the key's slot.
    std::uint32_t add(std::uint64_t key, std::uint64_t position, std::uint8_t level) {
        std::uint64_t s = lattice::hash(key) & mask_;
        for (;; s = (s + 1) & mask_) {
            std::uint64_t k = keys_[s].load(std::memory_order_relaxed);
            if (k == lattice::kEmptyKey && keys_[s].compare_exchange_strong(k, key, std::memory_order_relaxed)) break;
            if (k == key) break;
        }
        lower(first_[s], position);
        lower(level_[s], level);
        return std::uint32_t(s);
    }
    bool first_at(std::uint32_t slot, std::uint64_t position) const { return first_[slot].load(std::memory_order_relaxed) == position; }
    std::uint8_t level(std::uint32_t slot) const { return level_[slot].load(std::memory_order_relaxed); }
    std::uint32_t& id(std::uint32_t slot) { return id_[slot]; }

private:
    template <class T>
    static void lower(std::atomic<T>& a, T v) {
        T cur = a.load(std::memory_order_relaxed);
        while (v < cur && !a.compare_exchange_weak(cur, v, std::memory_order_relaxed)) {
        }
    }
    std::uint64_t mask_ = 0;
    std::unique_ptr<std::atomic<std::uint64_t>[]> keys_, first_;
    std::unique_ptr<std::atomic<std::uint8_t>[]> level_;
    std::vector<std::uint32_t> id_;
};

// Phase 2 on many threads, after all chunks are meshed: numbers the vertices as number_chunk()
// does, on all threads, giving the same numbers. Only vertices on a cell boundary can
// repeat, so only they go through SharedVertices; a vertex made by any level-2 cube is level 2.
// Four passes over the chunks: shared vertices added; each chunk's new vertices counted; their
// numbers given from the chunks' prefix sums (positions and levels written); the repeats
// resolved. ids[ci][v] holds a shared vertex's slot until then; the count marks a repeat with
// shared[v] == 2, so that only it probes the table for first appearances.
void number_vertices(std::vector<ChunkOut>& chunks, std::vector<std::vector<std::uint32_t>>& ids, Mesh& mesh) {
    const std::size_t nc = chunks.size();
    auto each_chunk = [&](auto&& f) {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nc, 1), [&](const auto& r) {
            for (std::size_t ci = r.begin(); ci != r.end(); ++ci) f(ci, chunks[ci]);
        });
    };
    auto position = [](std::size_t ci, std::size_t v) { return (std::uint64_t(ci) << 32) | std::uint64_t(v); };
    std::vector<std::size_t> count(nc + 1, 0);
    each_chunk([&](std::size_t ci, const ChunkOut& c) {
        count[ci + 1] = std::size_t(std::count(c.shared.begin(), c.shared.end(), std::uint8_t(1)));
    });
    std::size_t shared = 0;
    for (std::size_t ci = 0; ci < nc; ++ci) shared += count[ci + 1];
    SharedVertices table(shared);
    each_chunk([&](std::size_t ci, const ChunkOut& c) {
        ids[ci].resize(c.keys.size());
        for (std::size_t v = 0; v < c.keys.size(); ++v)
            if (c.shared[v]) ids[ci][v] = table.add(c.keys[v], position(ci, v), c.level[v]);
    });
    each_chunk([&](std::size_t ci, ChunkOut& c) {
        std::size_t n = 0;
        for (std::size_t v = 0; v < c.keys.size(); ++v) {
            if (c.shared[v] && !table.first_at(ids[ci][v], position(ci, v))) c.shared[v] = 2;  // a repeat, its slot kept
            n += c.shared[v] != 2;
        }
        count[ci + 1] = n;
    });
    for (std::size_t ci = 0; ci < nc; ++ci) count[ci + 1] += count[ci];
    mesh.positions.resize(3 * count[nc]);
    mesh.vertex_level.resize(count[nc]);
    each_chunk([&](std::size_t ci, ChunkOut& c) {
        std::uint32_t next = std::uint32_t(count[ci]);
        for (std::size_t v = 0; v < c.keys.size(); ++v) {
            if (c.shared[v] == 2) continue;
            const std::uint32_t id = next++;
            std::copy_n(&c.positions[v].x, 3, mesh.positions.begin() + 3 * std::ptrdiff_t(id));
            mesh.vertex_level[id] = c.shared[v] ? table.level(ids[ci][v]) : c.level[v];
            if (c.shared[v]) table.id(ids[ci][v]) = id;
            ids[ci][v] = id;
        }
    });
    each_chunk([&](std::size_t ci, ChunkOut& c) {
        for (std::size_t v = 0; v < c.keys.size(); ++v)
            if (c.shared[v] == 2) ids[ci][v] = table.id(ids[ci][v]);
        release_vertices(c);
    });
}

// The chunks' crack runs with global vertex ids, in chunk order (host/crack_collapse.hpp).
CrackRuns global_runs(const std::vector<ChunkOut>& chunks, const std::vector<std::vector<std::uint32_t>>& ids) {
    CrackRuns runs;
    for (std::size_t ci = 0; ci < chunks.size(); ++ci) {
        const auto& local = chunks[ci].crack_runs;
        for (std::size_t i = 0; i < local.size(); i += local[i] + 1) {
            runs.push_back(local[i]);
            for (std::size_t k = 1; k <= local[i]; ++k) runs.push_back(ids[ci][local[i + k]]);
        }
    }
    return runs;
}

}  // namespace

Mesh triangulate_cells(const std::vector<CoarseCell>& cells, const LatticeFrame& lattice_frame, const FinePointMap& field,
                       CrackClosing closing, std::size_t* collapsed,
                       const std::function<void(const std::vector<float>&)>& beside_collapse, std::vector<std::uint32_t>* kept,
                       const std::function<void()>& field_done) {
    if (lattice_frame.coarse_steps < 2 || lattice_frame.coarse_steps % 2)
        throw Error("triangulation: coarse_steps must be even");
    const CellIndex cell_index(cells);
    const CellMesher mesher(lattice_frame, field, cell_index);
    const std::size_t nc = (cells.size() + kCellsPerChunk - 1) / kCellsPerChunk;
    std::vector<ChunkOut> chunks(nc);
    std::vector<std::vector<std::uint32_t>> ids(nc);
    Mesh mesh;
    auto mesh_chunk = [&](std::size_t ci, Scratch& s) {
        const std::size_t end = std::min(cells.size(), (ci + 1) * kCellsPerChunk);
        for (std::size_t i = ci * kCellsPerChunk; i < end; ++i) mesher.mesh(cells[i], s, chunks[ci]);
    };
    {
        tbb::enumerable_thread_specific<Scratch> scratch;
        if (tbb::this_task_arena::max_concurrency() < kNumberingThreads) {
            // Phases 1-2 as a pipeline: chunks are meshed in parallel and numbered in order
            // meanwhile, which hides the numbering behind the meshing and frees each chunk's
            // vertices at once (the peak of a run on few cores).
            // Vertices on cell boundaries per cell: 2.0 (db23), 2.3 (x64 adaptive), 3.7 (x64 uniform r).
            VertexIndex index(cells.size() * 4);
            std::size_t next = 0;
            tbb::parallel_pipeline(
                4 * std::size_t(tbb::this_task_arena::max_concurrency()),
                tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                                    [&](tbb::flow_control& fc) -> std::size_t {
                                                        if (next == nc) fc.stop();
                                                        return next++;
                                                    }) &
                    tbb::make_filter<std::size_t, std::size_t>(tbb::filter_mode::parallel,
                                                               [&](std::size_t ci) {
                                                                   mesh_chunk(ci, scratch.local());
                                                                   return ci;
                                                               }) &
                    tbb::make_filter<std::size_t, void>(tbb::filter_mode::serial_in_order,
                                                        [&](std::size_t ci) { number_chunk(chunks[ci], index, ids[ci], mesh); }));
        } else {
            // Many threads mesh faster than one numbers (about 50 ms of x64 on 16 cores), so the
            // chunks are meshed first and numbered on all threads.
            tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nc, 1), [&](const auto& r) {
                for (std::size_t ci = r.begin(); ci != r.end(); ++ci) mesh_chunk(ci, scratch.local());
            });
            number_vertices(chunks, ids, mesh);
        }
    }  // the index is freed before phase 3 allocates the mesh's triangles (the run's peak at x64)
    if (field_done) field_done();  // and the field, which nothing below reads

    const CrackRuns runs = closing == CrackClosing::Collapse ? global_runs(chunks, ids) : CrackRuns{};
    // Phase 3: triangles with global indices, in chunk order.
    std::vector<std::size_t> tri_offset(nc + 1, 0);
    for (std::size_t ci = 0; ci < nc; ++ci) tri_offset[ci + 1] = tri_offset[ci] + chunks[ci].kinds.size();
    mesh.triangles.resize(tri_offset.back() * 3);
    mesh.triangle_kind.resize(tri_offset.back());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nc, 1), [&](const auto& r) {
        for (std::size_t ci = r.begin(); ci != r.end(); ++ci) {
            ChunkOut& c = chunks[ci];
            std::uint32_t* t = mesh.triangles.data() + tri_offset[ci] * 3;
            for (std::size_t i = 0; i < c.triangles.size(); ++i) t[i] = ids[ci][c.triangles[i]];
            std::copy(c.kinds.begin(), c.kinds.end(), mesh.triangle_kind.begin() + std::ptrdiff_t(tri_offset[ci]));
            c = ChunkOut{};  // copied: freed while the others are
            release(ids[ci]);
        }
    });
    std::size_t merged = 0;
    auto collapse = [&] { merged = collapse_crack_runs(mesh, runs, kept); };
    if (beside_collapse) {
        const std::vector<float> positions = mesh.positions;  // a copy: the collapse's compaction moves them
        run_beside([&] { beside_collapse(positions); }, collapse);
    } else {
        collapse();
    }
    if (collapsed) *collapsed = merged;
    return mesh;
}

}  // namespace trilevel
