#include "device_stages.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numeric>
#include <optional>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "core/cell_index.hpp"
#include "kernel_contract.hpp"
#include "kernel_launch.hpp"
#include "stage_constants.hpp"

namespace trilevel {
namespace {

using kernels::Groups;
using kernels::Items;

/// A device buffer (role `what`) holding a copy of `data`: the counterpart of read_buffer. Empty
/// data gives a buffer with nothing written (a write of 0 bytes is CL_INVALID_VALUE).
template <class T>
DeviceBuffer upload(OpenCLRuntime& rt, const std::vector<T>& data, const char* what) {
    DeviceBuffer buf = rt.buffer(data.size() * sizeof(T), what);
    if (!data.empty()) rt.queue().enqueueWriteBuffer(buf, CL_TRUE, 0, data.size() * sizeof(T), data.data());
    return buf;
}

/// A table of at least `capacity` slots (1024 at least), rounded up to a power of two unless
/// `exact`. The particle bins keep the power of two: their slot order is the particles' sorted
/// order, and the low-bit layout keeps it cache-friendly (home_slot in hash_table.cl). The
/// coarse-cell and fine-point tables are sized to what they hold (the fine points are most of
/// the peak memory).
/// `key_bytes`: 8, or 4 for a fine-point table in a 32-bit lattice::KeyLayout.
DeviceHash make_hash(OpenCLRuntime& rt, std::size_t capacity, const char* what,
                     cl_mem_flags flags = CL_MEM_READ_WRITE, bool exact = false, std::size_t key_bytes = 8) {
    DeviceHash h;
    capacity = std::max<std::size_t>(capacity, 1024);
    h.capacity = lattice::table_capacity(exact ? capacity : std::bit_ceil(capacity));
    h.keys = rt.buffer(h.capacity * key_bytes, what, flags);
    h.stats = rt.buffer(2 * sizeof(cl_int), (std::string(what) + " counters").c_str());
    rt.queue().enqueueFillBuffer(h.keys, ~cl_uint{0}, 0, h.capacity * key_bytes);  // all ones: empty
    rt.queue().enqueueFillBuffer(h.stats, cl_int{0}, 0, 2 * sizeof(cl_int));
    return h;
}

struct HashCounters {
    bool overflow;
    std::size_t inserted;
};
HashCounters read_counters(OpenCLRuntime& rt, const DeviceHash& h) {
    cl_int s[2];
    rt.queue().enqueueReadBuffer(h.stats, CL_TRUE, 0, sizeof(s), s);
    return {s[0] != 0, std::size_t(s[1])};
}
/// Whether a table that took `c` must grow: it overflowed, or holds more than `max_load` of its slots.
bool needs_growth(const HashCounters& c, const DeviceHash& h, double max_load = 0.5) {
    return c.overflow || double(c.inserted) > max_load * double(h.capacity);
}

/// Slots that hold `keys` keys at load factor `load`.
std::size_t capacity_for(std::size_t keys, double load) {
    return std::size_t(double(keys) / load) + 1;
}

/// The capacity a table that must grow gets: twice its own, or `load` (docs/design.md §5: 1/2) for what it took.
std::size_t grown_capacity(const DeviceHash& h, const HashCounters& c, double load = 0.5) {
    return std::max(h.capacity * 2, capacity_for(c.inserted, load));
}

/// Runs `insert` into a fresh table until it fits at load factor <= 0.5 (docs/design.md §5); `exact` as
/// in make_hash.
template <class Insert>
DeviceHash insert_growing(OpenCLRuntime& rt, std::size_t capacity, const char* what, bool exact, Insert insert) {
    for (;;) {
        DeviceHash h = make_hash(rt, capacity, what, CL_MEM_READ_WRITE, exact);
        insert(h);
        HashCounters c = read_counters(rt, h);
        if (!needs_growth(c, h)) return h;
        capacity = grown_capacity(h, c);
    }
}

// Work-group sizes: a bin holds about (R / 2r)^3 = 8 particles, a level-3 cell 125 points.
constexpr std::size_t kBinGroup = 8, kCellGroup = 16;  // a work-item takes 8 particles or points at once
constexpr std::size_t kBinsPerGroup = 16;  // bins one work-group takes in turn

/// The __local candidate lists of a gather (particle_binning.cl) on this device.
kernels::CandidateLists candidate_lists(const OpenCLRuntime& rt) { return {rt.max_candidates()}; }

/// The occupied bin slots in Morton order of their coordinates, and each slot's (first, count)
/// range laid out in that order (unoccupied slots: empty): bins near in space are then near in
/// memory and in the order work-groups take them, so a bin's 27-bin gather mostly finds its
/// neighbours' particles in cache. Sums do not change: a gather orders candidates by bin position,
/// not by range. Returns the sum of squared bin counts (the neighbour-pair load).
std::uint64_t order_bins(const MappedBuffer<cl_uint>& counts, const MappedBuffer<cl_ulong>& keys, std::size_t cap,
                         std::vector<cl_uint>& occupied, const MappedBuffer<cl_uint2>& range) {
    occupied.clear();
    for (std::size_t s = 0; s < cap; ++s)
        if (counts[s]) occupied.push_back(cl_uint(s));
    lattice::sort_by_morton(occupied, [&](cl_uint s) { return lattice::unpack(keys[s]); });
    std::fill(&range[0], &range[0] + cap, cl_uint2{{0, 0}});
    cl_uint sum = 0;
    std::uint64_t pairs = 0;
    for (cl_uint s : occupied) {
        range[s] = {{sum, counts[s]}};
        sum += counts[s];
        pairs += std::uint64_t(counts[s]) * counts[s];
    }
    return pairs;
}

}  // namespace

BinnedParticles bin_particles(OpenCLRuntime& rt, const float* xyz, std::size_t particles, glm::dvec3 origin, float cell,
                              const std::function<void()>& uploaded, const PairLoadCheck& check_load) {
    const cl_uint n = cl_uint(particles);
    DeviceBuffer pos = rt.buffer(n * sizeof(glm::vec3), "particle positions");  // packed xyz
    {
        const MappedBuffer<glm::vec3> p(rt, pos, n, CL_MAP_WRITE_INVALIDATE_REGION);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles, 1 << 16), [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i)
                p[i] = glm::vec3(glm::dvec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]) - origin);
        });
    }
    if (uploaded) uploaded();
    return bin_positions(rt, std::move(pos), particles, cell, check_load);
}

BinnedParticles bin_positions(OpenCLRuntime& rt, DeviceBuffer pos, std::size_t particles, float cell,
                              const PairLoadCheck& check_load) {
    BinnedParticles b;
    b.count = particles;
    b.cell = cell;
    const cl_uint n = cl_uint(b.count);
    const float inv_cell = 1.0f / cell;
    DeviceBuffer slot_of = rt.buffer(n * sizeof(cl_int), "particle bins");

    b.bins = insert_growing(rt, std::size_t(float(b.count) * constants::kBinSlotsPerParticle), "particle bin hash", false, [&](DeviceHash& h) {
        kernels::bin_insert(rt, Items{n}, pos, n, inv_cell, h.keys, cl_ulong(h.capacity), slot_of, h.stats);
    });
    const std::size_t cap = b.bins.capacity;
    DeviceBuffer count = rt.buffer(cap * sizeof(cl_uint), "bin counts");
    rt.queue().enqueueFillBuffer(count, cl_uint{0}, 0, cap * sizeof(cl_uint));
    kernels::bin_count(rt, Items{n}, slot_of, n, count);

    b.range = rt.buffer(cap * sizeof(cl_uint2), "bin ranges");
    {  // counts and keys read, ranges written through maps: no host copies of the tables
        std::vector<cl_uint> occupied;
        b.pair_load = order_bins(MappedBuffer<cl_uint>(rt, count, cap, CL_MAP_READ),
                                 MappedBuffer<cl_ulong>(rt, b.bins.keys, cap, CL_MAP_READ), cap, occupied,
                                 MappedBuffer<cl_uint2>(rt, b.range, cap, CL_MAP_WRITE_INVALIDATE_REGION));
        b.occupied_count = occupied.size();
        b.occupied = upload(rt, occupied, "occupied bins");
    }
    if (check_load) check_load(b.pair_load);
    rt.queue().enqueueFillBuffer(count, cl_uint{0}, 0, cap * sizeof(cl_uint));
    b.order = rt.buffer(n * sizeof(cl_uint), "particle order");
    kernels::bin_scatter(rt, Items{n}, slot_of, n, b.range, count, b.order);
    slot_of = DeviceBuffer{};  // not needed once scattered: the gather below is the stage's peak
    count = DeviceBuffer{};
    kernels::bin_sort_buckets(rt, Items{cap}, b.range, cl_ulong(cap), b.order);
    b.sorted = rt.buffer(n * 3 * sizeof(cl_float), "sorted positions");
    kernels::bin_gather(rt, Items{n}, b.order, n, pos, b.sorted);
    rt.finish();
    return b;
}

ParticleClasses classify_particles(OpenCLRuntime& rt, const BinnedParticles& b, float r, float R) {
    ParticleClasses c;
    const cl_uint n = cl_uint(b.count);
    c.gradient = rt.buffer(n * 3 * sizeof(cl_float), "colour-field gradients");
    c.flags = rt.buffer(n * sizeof(cl_uchar), "particle flags");
    const float volume = std::pow(2.0f * r, 3.0f);
    kernels::color_field(rt, Groups{(b.occupied_count + kBinsPerGroup - 1) / kBinsPerGroup, kBinGroup}, b.sorted,
                         b.occupied, cl_uint(b.occupied_count), cl_uint(kBinsPerGroup), 1.0f / b.cell, b.bins.keys,
                         cl_ulong(b.bins.capacity), b.range, R, volume, constants::sheet_neighbour_limit(R, volume), c.gradient,
                         c.flags, candidate_lists(rt));
    for (cl_uchar f : read_buffer<cl_uchar>(rt, c.flags, n)) {
        c.surface += (f & contract::kFlagSurface) ? 1 : 0;
        c.splash += (f & contract::kFlagSplash) ? 1 : 0;
    }
    return c;
}

namespace {

/// Stage 4 on the device: per-particle curvature summed into the coarse cells, per-cell mean, levels
/// (paper eq. 1-3). With keep_kappa the per-particle curvature is also written to `kappa`. The
/// per-cell passes take the `count` slots of `morton_cells`; cell_blocks looks up each one's 3x3x3
/// block once, in that order, so the probes mostly hit the cache (x512: 620 k cells in 2.1 M slots,
/// scattered by the hash), and the curvature passes read the 27 slots it wrote (108 bytes a cell).
void cell_curvature_levels(OpenCLRuntime& rt, const BinnedParticles& b, ParticleClasses& c,
                           const DeviceHash& cells, const cl::Buffer& morton_cells, cl_uint count,
                           const cl::Buffer& cell_flags, float R, float inv_coarse, float threshold,
                           DeviceBuffer& level, DeviceBuffer& cell_kappa, bool keep_kappa, DeviceBuffer& kappa) {
    const cl_uint n = cl_uint(b.count);
    const std::size_t cap = cells.capacity;
    DeviceBuffer sum = rt.buffer(cap * sizeof(cl_ulong), "cell curvature sums");
    DeviceBuffer cnt = rt.buffer(cap * sizeof(cl_uint), "cell curvature counts");
    DeviceBuffer mx = rt.buffer(cap * sizeof(cl_uint), "cell curvature maxima");
    rt.queue().enqueueFillBuffer(sum, cl_ulong{0}, 0, cap * sizeof(cl_ulong));
    rt.queue().enqueueFillBuffer(cnt, cl_uint{0}, 0, cap * sizeof(cl_uint));
    rt.queue().enqueueFillBuffer(mx, cl_uint{0}, 0, cap * sizeof(cl_uint));
    kappa = rt.buffer(keep_kappa ? n * sizeof(cl_float) : sizeof(cl_float), "particle curvature");
    const cl::Buffer& normals = c.gradient;  // turned into normals in place
    kernels::particle_normals(rt, Items{n}, c.gradient, n);
    kernels::particle_curvature(rt, Groups{(b.occupied_count + kBinsPerGroup - 1) / kBinsPerGroup, kBinGroup}, b.sorted,
                                c.flags, b.occupied, cl_uint(b.occupied_count), cl_uint(kBinsPerGroup), 1.0f / b.cell,
                                b.bins.keys, cl_ulong(b.bins.capacity), b.range, normals, R, cl_uint(keep_kappa),
                                candidate_lists(rt), kernels::Local<cl_float4>{rt.max_candidates()} /* their normals */,
                                inv_coarse, cells.keys, cl_ulong(cells.capacity), sum, cnt, mx, kappa);
    c.gradient = DeviceBuffer{};  // normals and flags are read: freed before the buffers below
    c.flags = DeviceBuffer{};
    DeviceBuffer block = rt.buffer(std::size_t(count) * 27 * sizeof(cl_uint), "coarse cell blocks");
    kernels::cell_blocks(rt, Items{count}, morton_cells, count, cells.keys, cl_ulong(cells.capacity), block);
    DeviceBuffer raw = rt.buffer(cap * sizeof(cl_float), "cell curvature, smoothing");
    kernels::cell_curvature(rt, Items{count}, morton_cells, count, block, sum, cnt, mx, raw);
    // Ping-pong between raw and cell_kappa; the smoothed curvature ends in cell_kappa.
    for (int pass = 0; pass < constants::kCurvatureSmoothingPasses; ++pass) {
        kernels::smooth_cell_curvature(rt, Items{count}, morton_cells, count, block, raw, cell_kappa);
        if (pass + 1 < constants::kCurvatureSmoothingPasses) std::swap(raw, cell_kappa);
    }
    kernels::cell_levels(rt, Items{count}, morton_cells, count, cell_kappa, cell_flags, threshold, level);
    kernels::cell_thin_bodies(rt, Items{count}, morton_cells, count, block, cell_flags);
}

}  // namespace

SurfaceCells surface_cells(OpenCLRuntime& rt, const BinnedParticles& b, ParticleClasses& c, float r, float R,
                           float coarse_edge, float threshold, int forced_level, bool read_particle_kappa) {
    const cl_uint n = cl_uint(b.count);
    const float inv_coarse = 1.0f / coarse_edge;
    const float half_box = constants::kSurfaceBoxHalf * r;
    const auto first_capacity = std::size_t(float(c.surface + c.splash) * constants::kCoarseCellsPerSurfaceParticle);
    DeviceHash cells = insert_growing(rt, first_capacity, "coarse cell hash", true, [&](DeviceHash& h) {
        kernels::mark_surface_cells(rt, Items{n}, b.sorted, c.flags, n, inv_coarse, half_box, h.keys,
                                    cl_ulong(h.capacity), h.stats);
    });
    const std::size_t cap = cells.capacity;
    DeviceBuffer flags = rt.buffer(cap * sizeof(cl_uint), "coarse cell flags");
    rt.queue().enqueueFillBuffer(flags, cl_uint{0}, 0, cap * sizeof(cl_uint));
    kernels::mark_cell_flags(rt, Items{n}, b.sorted, c.flags, n, inv_coarse, constants::kSplashBoxHalf * r, cells.keys,
                             cl_ulong(cells.capacity), flags, cl_uint(forced_level == 0));

    // The cells' slots in key order (the output's) and in Morton order (the per-cell passes'). The
    // keys are read through a map (no host copy on CPU devices); the kernels below only read them.
    const MappedBuffer<cl_ulong> keys(rt, cells.keys, cap, CL_MAP_READ);
    std::vector<cl_uint> slots;
    for (std::size_t s = 0; s < cap; ++s)
        if (keys[s] != lattice::kEmptyKey) slots.push_back(cl_uint(s));
    DeviceBuffer level = rt.buffer(cap, "coarse cell levels"), cell_kappa, kappa;
    SurfaceCells out;
    if (forced_level == 0) {
        std::vector<cl_uint> morton = slots;
        lattice::sort_by_morton(morton, [&](cl_uint s) { return lattice::unpack(keys[s]); });
        const DeviceBuffer list = upload(rt, morton, "coarse cells in Morton order");
        cell_kappa = rt.buffer(cap * sizeof(cl_float), "coarse cell curvature");
        cell_curvature_levels(rt, b, c, cells, list, cl_uint(morton.size()), flags, R, inv_coarse, threshold, level,
                              cell_kappa, read_particle_kappa, kappa);
        if (read_particle_kappa) out.particle_kappa = read_buffer<float>(rt, kappa, n);
    }
    c.gradient = DeviceBuffer{};  // uniform modes: not needed after the splash cells
    c.flags = DeviceBuffer{};
    tbb::parallel_sort(slots.begin(), slots.end(), [&](cl_uint a, cl_uint b2) { return keys[a] < keys[b2]; });
    const MappedBuffer<cl_uint> fl(rt, flags, cap, CL_MAP_READ);
    std::optional<MappedBuffer<cl_uchar>> lv;
    std::optional<MappedBuffer<float>> kv;
    if (forced_level == 0) {
        lv.emplace(rt, level, cap, CL_MAP_READ);
        kv.emplace(rt, cell_kappa, cap, CL_MAP_READ);
    }
    out.cells.reserve(slots.size());
    for (std::size_t s : slots) {
        out.cells.push_back({lattice::unpack(keys[s]), std::uint8_t(forced_level ? forced_level : (*lv)[s])});
        out.splash.push_back(std::uint8_t((fl[s] & contract::kCellSplash) != 0));
        out.thin_body.push_back(std::uint8_t((fl[s] & contract::kCellThinBody) != 0));
        out.curvature.push_back(forced_level ? 0.0f : (*kv)[s]);
    }
    rt.finish();
    return out;
}

namespace {

/// Whether cell i of `cells` gets the centres of its level-2 cubes: a level-2 cell flagged in
/// `cube_centres` (empty: none is).
bool takes_cube_centres(const std::vector<CoarseCell>& cells, const std::vector<std::uint8_t>& cube_centres,
                        std::size_t i) {
    return cells[i].level == 2 && !cube_centres.empty() && cube_centres[i];
}

/// Unique points a batch of cells adds, for sizing the table (interior points are shared by none).
std::size_t estimate_points(const std::vector<CoarseCell>& cells, const std::vector<std::uint8_t>& cube_centres,
                            int coarse_steps) {
    const std::size_t cubes = std::size_t(coarse_steps / 2);
    std::size_t total = 0;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        const CoarseCell& c = cells[i];
        if (takes_cube_centres(cells, cube_centres, i)) total += cubes * cubes * cubes;
        std::size_t side = std::size_t(coarse_steps / stride(c.level));
        // A cell owns about side^3 points (neighbours share the rest), plus some on faces without a
        // neighbour. Underestimates only cost a rehash (the table grows past FinePoints::kMaxLoad).
        total += side * side * side + side * side / 2;
        // Refined midpoints of crossed edges (edge_refinement.hpp): about 2 a level-2 cell on the
        // dam-break frames; more here oversizes the largest table (bench/RESULTS-implementation.md).
        if (c.level == 2) total += side * side / 2;
    }
    return total;
}

/// Selects the program built for the table's key width (FINE_KEY_BITS in kernels/hash_table.cl)
/// for the fine-point kernels launched next.
void use_key_width(OpenCLRuntime& rt, const FinePoints& p) { rt.set_fine_key_bits(p.layout.wide ? 64 : 32); }

/// The layout as the kernels take it: the shifts of y and z.
cl_uint2 key_shifts(const lattice::KeyLayout& l) { return {{cl_uint(l.y_shift), cl_uint(l.z_shift)}}; }

/// The table takes the lattice's key layout when it is made; every point it will hold must fit it
/// (make_grid sizes it with margin: a point outside would alias another one, so this is checked).
void adopt_layout(FinePoints& p, const LatticeFrame& lattice_frame, const std::vector<CoarseCell>& cells) {
    if (p.hash.capacity == 0) p.layout = lattice_frame.keys;
    else if (p.layout != lattice_frame.keys)
        throw Error("internal: a fine-point table is refined with a lattice of another key layout");
    for (const CoarseCell& c : cells)
        if (!p.layout.holds(c.coord * lattice_frame.coarse_steps) ||
            !p.layout.holds((c.coord + 1) * lattice_frame.coarse_steps))
            throw Error("internal: coarse cell (" + std::to_string(c.coord.x) + ", " + std::to_string(c.coord.y) + ", " +
                        std::to_string(c.coord.z) + ") lies outside the fine-point key layout");
}

void grow_fine_points(OpenCLRuntime& rt, FinePoints& p, std::size_t capacity) {
    // Host-accessible, so that mapping the table for the host stages costs no copy on CPU devices.
    constexpr cl_mem_flags kShared = CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR;
    DeviceHash h = make_hash(rt, capacity, "fine point hash", kShared, true, p.layout.key_bytes());
    DeviceBuffer values = rt.buffer(h.capacity * sizeof(cl_float), "fine point values", kShared);
    rt.queue().enqueueFillBuffer(values, std::numeric_limits<float>::quiet_NaN(), 0, h.capacity * sizeof(cl_float));
    if (p.hash.capacity) {
        use_key_width(rt, p);
        kernels::fine_rehash(rt, Items{p.hash.capacity}, p.hash.keys, p.values, cl_ulong(p.hash.capacity), h.keys, values,
                             cl_ulong(h.capacity), key_shifts(p.layout), h.stats);
    }
    p.hash = std::move(h);  // the old table goes back to the pool (queued commands keep their order)
    p.values = std::move(values);
}

/// Grows the table to FinePoints::kTargetLoad when `keys` points would pass FinePoints::kMaxLoad
/// of it. The table is sized to what it holds, not to a power of two (bench/RESULTS-implementation.md).
void ensure_fine_room(OpenCLRuntime& rt, FinePoints& p, std::size_t keys) {
    if (double(keys) > FinePoints::kMaxLoad * double(p.hash.capacity)) grow_fine_points(rt, p, capacity_for(keys, FinePoints::kTargetLoad));
}

/// After an insert pass into the fine-point table: records its count, and grows the table when
/// the pass overflowed it or left it past FinePoints::kMaxLoad. True when it grew (inserting is
/// idempotent: the caller runs the pass again).
bool grew_after_insert(OpenCLRuntime& rt, FinePoints& p) {
    const HashCounters c = read_counters(rt, p.hash);
    p.inserted = c.inserted;
    if (!needs_growth(c, p.hash, FinePoints::kMaxLoad)) return false;
    grow_fine_points(rt, p, grown_capacity(p.hash, c, FinePoints::kTargetLoad));
    return true;
}

/// Cells as int4 (x, y, z, level) on the device; level-2 cells flagged in `cube_centres` (empty or
/// one flag per cell) carry contract::kCellCubeCentres in w, and with `mark_cells_above` the
/// cells above each one in the list (contract.h, CELL_ABOVE_SHIFT: for the inserting field pass).
/// `in_morton_order`: the cells in Morton order of their coordinates instead of the given order,
/// where nothing but the work-groups' memory locality depends on it (neighbouring cells then
/// run close in time, and their gathers and table lines are still in cache).
DeviceBuffer cell_buffer(OpenCLRuntime& rt, const std::vector<CoarseCell>& cells,
                         const std::vector<std::uint8_t>& cube_centres = {}, bool in_morton_order = false,
                         bool mark_cells_above = false) {
    std::vector<cl_int4> data(cells.size());
    std::optional<CellIndex> index;
    if (mark_cells_above) index.emplace(cells);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 4096), [&](const auto& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
            const CoarseCell& c = cells[i];
            std::int32_t w = c.level | (takes_cube_centres(cells, cube_centres, i) ? contract::kCellCubeCentres : 0);
            if (index)
                for (int d = 1; d < 8; ++d) {
                    const int level = index->level(c.coord + glm::ivec3(d & 1, (d >> 1) & 1, (d >> 2) & 1));
                    if (level) w |= (level == 3 ? 3 : 1) << (contract::kCellAboveShift + 2 * (d - 1));
                }
            data[i] = {{c.coord.x, c.coord.y, c.coord.z, w}};
        }
    });
    if (in_morton_order) lattice::sort_by_morton(data, [](const cl_int4& c) { return glm::ivec3(c.s[0], c.s[1], c.s[2]); });
    return upload(rt, data, "cell list");
}

/// Stage 6 over every point inserted but not evaluated yet, one work-item a point: each unique point
/// exactly once.
void evaluate_pending(OpenCLRuntime& rt, FinePoints& p, const LatticeFrame& lattice_frame, const BinnedParticles& b,
                      float r, float R) {
    DeviceBuffer count = rt.buffer(sizeof(cl_uint), "pending count");
    DeviceBuffer pending = rt.buffer(p.inserted * sizeof(cl_uint), "pending points");
    rt.queue().enqueueFillBuffer(count, cl_uint{0}, 0, sizeof(cl_uint));
    use_key_width(rt, p);
    kernels::collect_pending(rt, Items{p.hash.capacity}, p.hash.keys, p.values, cl_ulong(p.hash.capacity), count, pending);
    const cl_uint todo = read_buffer<cl_uint>(rt, count, 1)[0];
    kernels::scalar_field(rt, Items{todo}, pending, todo, p.hash.keys, p.values, lattice_frame.step, b.sorted,
                          1.0f / b.cell, b.bins.keys, cl_ulong(b.bins.capacity), b.range, r, R, key_shifts(p.layout));
    rt.finish();
}

/// What one pass of scalar_field_cells left to do.
struct CellPass {
    bool table_full = false;  ///< an inserting pass ran out of table: nothing else is known
    bool overflow = false;    ///< some cell's candidates did not fit: its points are still pending
};

/// One pass of scalar_field_cells over `cell_count` cells, one work-group per cell with candidates
/// gathered in local memory. `claim`: which pending points of its cell a work-group takes
/// (kernels/contract.h, CLAIM_*); the inserting modes also count what they inserted.
CellPass run_cell_pass(OpenCLRuntime& rt, FinePoints& p, const cl::Buffer& cell_buf, std::size_t cell_count,
                       ClaimPoints claim, const LatticeFrame& lattice_frame, const BinnedParticles& b, float r,
                       float R) {
    DeviceBuffer overflow = rt.buffer(sizeof(cl_int), "scalar field overflow flag");
    rt.queue().enqueueFillBuffer(overflow, cl_int{0}, 0, sizeof(cl_int));
    use_key_width(rt, p);
    const cl_int cells_are_bins = float(lattice_frame.coarse_steps) * lattice_frame.step == b.cell;
    kernels::scalar_field_cells(rt, Groups{cell_count, kCellGroup}, cell_buf, cl_int(lattice_frame.coarse_steps),
                                cl_int(claim), p.hash.keys, cl_ulong(p.hash.capacity), p.values, lattice_frame.step,
                                b.sorted, 1.0f / b.cell, b.bins.keys, cl_ulong(b.bins.capacity), b.range, r, R, overflow,
                                kernels::Local<cl_uint>{contract::kMaxBins}, kernels::Local<cl_uint>{contract::kMaxBins},
                                kernels::Local<cl_uint>{contract::kMaxCellPoints},
                                kernels::Local<cl_uint>{1}, cells_are_bins, p.hash.stats, key_shifts(p.layout),
                                kernels::Local<cl_float>{3 * contract::candidate_column(rt.max_candidates())});
    CellPass pass;
    pass.overflow = read_buffer<cl_int>(rt, overflow, 1)[0] != 0;
    if (contract::inserts(claim)) {
        const HashCounters c = read_counters(rt, p.hash);
        p.inserted = c.inserted;
        pass.table_full = c.overflow;
    }
    return pass;
}

/// Stage 6 over the points of `cell_count` cells that `claim` takes, then over what cells whose
/// candidates did not fit left pending: after an inserting pass the other cells holding those
/// points claim them (the claiming pass of the same points), and what no cell can take goes to the
/// per-point kernel. So which kernel evaluates a point depends only on the cells, never on timing.
/// False when an inserting pass filled the table: the caller grows it and runs the pass again.
bool evaluate_cells(OpenCLRuntime& rt, FinePoints& p, const cl::Buffer& cell_buf, std::size_t cell_count,
                    ClaimPoints claim, const LatticeFrame& lattice_frame, const BinnedParticles& b, float r, float R) {
    for (;;) {
        const CellPass pass = run_cell_pass(rt, p, cell_buf, cell_count, claim, lattice_frame, b, r, R);
        if (pass.table_full) return false;
        if (!pass.overflow) return true;
        if (!contract::inserts(claim)) {
            evaluate_pending(rt, p, lattice_frame, b, r, R);
            return true;
        }
        claim = claim == ClaimPoints::Inserted ? ClaimPoints::Level : ClaimPoints::EdgeMidpoints;
    }
}

}  // namespace

void refine_and_evaluate(OpenCLRuntime& rt, FinePoints& p, const std::vector<CoarseCell>& cells,
                         const LatticeFrame& lattice_frame, const BinnedParticles& b, float r, float R,
                         const std::vector<std::uint8_t>& cube_centres) {
    if (cells.empty()) return;
    if (!cube_centres.empty() && cube_centres.size() != cells.size())
        throw Error("internal: one cube-centre flag per refined cell expected");
    const DeviceBuffer cell_buf = cell_buffer(rt, cells, cube_centres, true, true);
    const std::size_t side = std::size_t(lattice_frame.coarse_steps + 1);
    const std::size_t work = cells.size() * side * side * side;
    if (work > std::numeric_limits<cl_uint>::max()) throw Error("too many fine points in one refinement pass");

    adopt_layout(p, lattice_frame, cells);
    ensure_fine_room(rt, p, p.inserted + estimate_points(cells, cube_centres, lattice_frame.coarse_steps));
    // One pass: each cell inserts its points and evaluates those it created.
    if (evaluate_cells(rt, p, cell_buf, cells.size(), ClaimPoints::Inserted, lattice_frame, b, r, R)) {
        ensure_fine_room(rt, p, p.inserted);
        rt.finish();
        return;
    }
    grow_fine_points(rt, p, p.hash.capacity * 2);  // full (the estimate fell short): the passes apart
    for (;;) {  // stage 5; inserting is idempotent, so after growth the pass simply runs again
        use_key_width(rt, p);
        kernels::refine_points(rt, Items{work}, cell_buf, cl_uint(cells.size()), cl_int(lattice_frame.coarse_steps),
                               p.hash.keys, cl_ulong(p.hash.capacity), p.hash.stats, key_shifts(p.layout));
        if (!grew_after_insert(rt, p)) break;
    }
    evaluate_cells(rt, p, cell_buf, cells.size(), ClaimPoints::Level, lattice_frame, b, r, R);
    rt.finish();
}

void refine_edges(OpenCLRuntime& rt, FinePoints& p, const std::vector<CoarseCell>& cells,
                  const LatticeFrame& lattice_frame, const BinnedParticles& b, float r, float R) {
    std::vector<CoarseCell> level2;
    for (const CoarseCell& c : cells)
        if (c.level == 2) level2.push_back(c);
    if (level2.empty()) return;
    if (lattice_frame.coarse_steps > 8)  // claim_refined_edges keeps a cell's corners and midpoints in local memory
        throw Error("internal: edge refinement takes coarse cells of at most 8 lattice steps");
    adopt_layout(p, lattice_frame, level2);
    ensure_fine_room(rt, p, p.inserted + 2 * level2.size());  // about 2 a level-2 cell (estimate_points)
    const DeviceBuffer cell_buf = cell_buffer(rt, level2, {}, true);
    bool grew = false;
    while (!evaluate_cells(rt, p, cell_buf, level2.size(), ClaimPoints::RefinedEdges, lattice_frame, b, r, R)) {
        grow_fine_points(rt, p, p.hash.capacity * 2);  // full: inserting is idempotent, so the pass runs again
        grew = true;
    }
    ensure_fine_room(rt, p, p.inserted);
    // A point created in a pass that ran out of room, by a cell whose candidates did not fit, is
    // not created again: the claiming pass takes it (it raises no overflow flag the second time).
    if (grew) evaluate_cells(rt, p, cell_buf, level2.size(), ClaimPoints::EdgeMidpoints, lattice_frame, b, r, R);
    rt.finish();
}

MappedFinePoints map_fine_points(OpenCLRuntime& rt, FinePoints& p) {
    rt.finish();
    MappedFinePoints m;
    if (p.hash.capacity == 0) return m;  // no surface cell: no table
    const std::size_t cap = p.hash.capacity;
    m.keys = MappedBuffer<std::uint8_t>(rt, p.hash.keys, cap * p.layout.key_bytes(), CL_MAP_READ | CL_MAP_WRITE);
    m.values = MappedBuffer<float>(rt, p.values, cap, CL_MAP_READ | CL_MAP_WRITE);
    m.view = FinePointMap::view(m.keys.data(), m.values.data(), cap, p.layout);
    return m;
}

void MappedFinePoints::unmap(OpenCLRuntime& rt) {
    view = FinePointMap();
    keys.unmap();
    values.unmap();
    rt.queue().finish();
}

}  // namespace trilevel
