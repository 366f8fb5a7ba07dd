// Pipeline orchestration (docs/design.md §2): device stages 1-6, then band closure, transition
// continuity and the edge refinement (on the device), triangulation and crack closing on
// the host. Each stage is a StageScope (stage_scope.hpp): timed on its own, and named in OpenCL errors.
#include <array>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <limits>
#include <optional>
#include <type_traits>
#include <unordered_map>

#include <sys/resource.h>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include "band_closure.hpp"
#include "core/run_beside.hpp"
#include "edge_collapse.hpp"
#include "device_input.hpp"
#include "device_stages.hpp"
#include "domain_split.hpp"
#include "environment.hpp"
#include "io/io_common.hpp"
#include "isolated_pieces.hpp"
#include "level2_check.hpp"
#include "level_history.hpp"
#include "mesh_clip.hpp"
#include "mesh_components.hpp"
#include "particle_box.hpp"
#include "mesh_smoothing.hpp"
#include "opencl_runtime.hpp"
#include "sliver_cleanup.hpp"
#include "stage_constants.hpp"
#include "stage_scope.hpp"
#include "surface_mesher.hpp"
#include "transition_continuity.hpp"
#include "vertex_data.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {

float default_curvature_threshold() { return constants::kDefaultCurvatureThreshold; }

const char* const kUniformCellRule = "must be 4/n radii for an even n from 2 to 64 (e.g. 2, 1, 0.5 or 0.25)";

bool is_uniform_cell(float cell) {
    if (!std::isfinite(cell) || cell <= 0.0f) return false;
    const float steps = constants::kCoarseCell / cell;
    const float n = std::round(steps);
    return std::fabs(steps - n) <= 1e-4f * n && n >= 2.0f && n <= 64.0f && std::fmod(n, 2.0f) == 0.0f;
}

namespace {

using Clock = std::chrono::steady_clock;

void require_positive(float v, const char* name, const char* why) {
    if (!std::isfinite(v) || v <= 0.0f)
        throw Error(std::string(name) + " must be finite and > 0 (" + why + "), got " + std::to_string(v));
}

}  // namespace

void check_params(const Params& p) {
    require_positive(p.particle_radius, "particle radius", "half the particle spacing, world units");
    require_positive(p.kernel_radius, "kernel radius", "in particle radii");
    if (p.kernel_radius < float(kMinKernelRadius) || p.kernel_radius > float(kMaxKernelRadius))
        throw Error("kernel radius must lie in [" + std::to_string(kMinKernelRadius) + ", " + std::to_string(kMaxKernelRadius) +
                    "] particle radii, got " + std::to_string(p.kernel_radius));
    if (p.mode == Mode::Uniform) {
        require_positive(p.cell, "cell size", "in particle radii");
        if (!is_uniform_cell(p.cell)) throw Error("cell size " + fmt(p.cell) + " " + kUniformCellRule);
    }
    if (p.normals != NormalMode::None && p.normals != NormalMode::Gradient && p.normals != NormalMode::Area)
        throw Error("normals must be NormalMode::None, Gradient or Area");
    if (!(std::isfinite(p.level2_tolerance) && p.level2_tolerance >= 0.0f))
        throw Error("level-2 tolerance must be finite and >= 0 (in r; 0 = off), got " + std::to_string(p.level2_tolerance));
    if (p.mode == Mode::Adaptive && p.curvature_threshold != 0.0f && !(std::isfinite(p.curvature_threshold) && p.curvature_threshold > 0.0f))
        throw Error("curvature threshold must be finite and > 0, got " + std::to_string(p.curvature_threshold));
    if (!(p.level_hysteresis >= 0.0f && p.level_hysteresis < 1.0f))
        throw Error("level hysteresis must lie in [0, 1) (a fraction of the curvature threshold), got " +
                    std::to_string(p.level_hysteresis));
    if (p.particle_box) validate_box(*p.particle_box, "particle box");
    if (p.clip_box) validate_box(*p.clip_box, "clip box");
    if (!(std::isfinite(p.remove_components_below) && p.remove_components_below >= 0.0f))
        throw Error("remove-components-below must be finite and >= 0 (particle volumes; 0 = off), got " +
                    std::to_string(p.remove_components_below));
    if (p.smooth_iterations < 0 || p.smooth_iterations > kMaxSmoothIterations)
        throw Error("smooth iterations must lie in [0, " + std::to_string(kMaxSmoothIterations) + "] (0: the default " +
                    std::to_string(kDefaultSmoothIterations) +
                    "), got " + std::to_string(p.smooth_iterations));
    if (p.memory_limit_bytes != 0 && p.memory_limit_bytes < 4096)
        throw Error("memory limit of " + std::to_string(p.memory_limit_bytes) +
                    " bytes cannot hold even the smallest buffers; give at least 4 KiB (0: the device's and host's memory)");
}

namespace {

/// Checks of the radius against the particles themselves (docs/design.md §4: clear errors, no garbage):
/// float32 coordinates must resolve the radius, and the kernel radius must stay in float range.
void validate_against(const Params& p, const Bounds& b) {
    const float far = float(b.max_abs);
    const double ulp = double(std::nextafter(far, INFINITY)) - double(far);
    if (ulp > 0.25 * p.particle_radius)
        throw Error("particle radius " + fmt(p.particle_radius) + ": the float32 coordinates cannot resolve it (they are " +
                    fmt(ulp) + " apart at |x| = " + fmt(b.max_abs) + "); check the radius, or move the particles nearer the origin");
    if (!(b.max_abs + 4.0 * double(p.kernel_radius) * p.particle_radius < double(std::numeric_limits<float>::max()) / 4))
        throw Error("particle radius " + fmt(p.particle_radius) + " times the kernel radius leaves the single-precision range");
}

/// Lengths are scaled by 2^k inside the pipeline when r lies outside [2^-10, 2^10]: the float
/// kernels raise R to the 9th power (poly6 normalisation), which under- or overflows for radii like
/// 1e-6 or 1e5. Scaling by a power of two is exact, so the mesh is the one of the scaled particles,
/// scaled back; radii inside the band are not touched at all.
int length_scale_exponent(float r) {
    if (r >= std::ldexp(1.0f, -10) && r <= std::ldexp(1.0f, 10)) return 0;
    return -std::ilogb(r);
}

/// Per axis, whether the adaptive lattice is shifted by r (one level-3 step) from the global
/// lattice of whole coarse cells: its level-2 planes then lie at odd multiples of r.
using LatticePhase = std::array<bool, 3>;

/// Per axis, r when most particles lie within r/4 of an odd multiple of r, else 0: a level-2 plane
/// then goes through every layer of a fluid made on a lattice of spacing 2r with its layers at odd
/// multiples of r (a simulator's first frames filled from a round corner, particles.py's generated
/// scenes). Its faces lie r beyond the outer layers, on even multiples: on level-2 planes they met
/// at edges along level-2 lines, which the 2r lattice rounds by up to 0.6 r (p99 0.55 r from the
/// uniform cell-r mesh); between the planes, p99 0.11 r. Disordered particles (a quarter of them
/// within r/4 of an odd multiple) and layers at even multiples keep phase 0, on which the levels
/// were calibrated (docs/calibration.md). The level-3 lattice, and so uniform r's, is the same in
/// both phases (steps of r). Judged on particles 0, step, 2 step, ... (phase_sample_step), which
/// the device path reads alike.
constexpr std::size_t kPhaseSamples = 4096;
std::size_t phase_sample_step(std::size_t n) { return std::max<std::size_t>(1, n / kPhaseSamples); }

/// The phase judged on particles 0, step, 2 step, ... of the n in `xyz` (x, y, z each).
LatticePhase lattice_phase_of(const float* xyz, std::size_t n, std::size_t step, double r) {
    LatticePhase phase{};
    const std::size_t m = (n + step - 1) / step;
    for (int a = 0; a < 3; ++a) {
        std::size_t on_odd = 0;
        for (std::size_t i = 0; i < n; i += step) {
            const double t = double(xyz[3 * i + std::size_t(a)]) / r;
            on_odd += std::fabs(t - (2.0 * std::floor(0.5 * t) + 1.0)) < 0.25;  // 2 floor(t/2) + 1: the nearest odd
        }
        phase[std::size_t(a)] = m > 0 && double(on_odd) > 0.75 * double(m);
    }
    return phase;
}

LatticePhase lattice_phase_for(const float* xyz, std::size_t n, double r) {
    return lattice_phase_of(xyz, n, phase_sample_step(n), r);
}

/// Lattice and coarse grid of a frame. Adaptive and uniform --cell 2 use lattice step r with
/// coarse cells of 4 steps (levels 3 and 2); other uniform cells use step = cell.
struct Grid {
    LatticeFrame lattice;  ///< the lattice's origin, step and key layout (what the stages take)
    glm::dvec3 origin;  ///< double-precision lattice origin; particles are uploaded relative to it
    CoarseBase coarse_base{};  ///< (origin - phase) / coarse_edge: a whole number, so frames share one lattice
    LatticePhase phase{};      ///< adaptive mode: lattice_phase_for (the same for every frame of a level history)
    float coarse_edge = 0.0f;
    int forced_level = 0;  ///< 0: adaptive
    double extent_steps = 0;  ///< lattice steps the particles and their margin span on the widest axis
};

Grid make_grid(const Params& p, const Bounds& b, const LatticePhase& phase) {
    Grid g;
    const double r = p.particle_radius;
    g.coarse_edge = float(constants::kCoarseCell * r);
    if (p.mode == Mode::Uniform) {
        int steps = int(std::lround(constants::kCoarseCell / p.cell));
        g.forced_level = (steps == 2) ? 2 : 3;
        g.lattice.coarse_steps = (steps == 2) ? 4 : steps;
    } else {
        g.lattice.coarse_steps = 4;
    }
    g.lattice.step = float(constants::kCoarseCell * r / g.lattice.coarse_steps);
    const glm::dvec3 lo(b.lo[0], b.lo[1], b.lo[2]), hi(b.hi[0], b.hi[1], b.hi[2]);
    const double edge = g.coarse_edge;
    // Two coarse cells of margin: the surface lies within R = one coarse cell of the particles.
    // Snapped to whole coarse cells plus the phase, so every frame of a sequence uses the same
    // global lattice (level_history.hpp).
    glm::dvec3 shift(0.0);
    if (p.mode == Mode::Adaptive) {
        g.phase = phase;
        for (int a = 0; a < 3; ++a) shift[a] = phase[std::size_t(a)] ? r : 0.0;
    }
    const glm::dvec3 base = glm::floor((lo - shift) / edge) - 2.0;
    g.origin = base * edge + shift;
    for (int a = 0; a < 3; ++a) g.coarse_base[std::size_t(a)] = std::int64_t(base[a]);
    g.lattice.origin = glm::vec3(g.origin);
    glm::dvec3 extent = (hi - g.origin) / double(g.lattice.step) + 3.0 * g.lattice.coarse_steps;
    g.extent_steps = std::max({extent.x, extent.y, extent.z});
    // 32-bit fine-point keys when the lattice fits them, with two more coarse cells of margin for
    // band closure (device_stages.cpp checks every cell against it); TRILEVEL_FINE_KEYS=64 keeps the
    // 64-bit ones (tests: both give the same mesh).
    const glm::ivec3 top = glm::ivec3(glm::min(glm::ceil(extent) + 2.0 * g.lattice.coarse_steps, glm::dvec3(lattice::kMaxCoord)));
    if (!environment().wide_fine_keys) g.lattice.keys = lattice::key_layout_for(top);
    return g;
}

/// Largest lattice extent one lattice takes; TRILEVEL_MAX_LATTICE_STEPS lowers it (tests: forces
/// the split path of domain_split.hpp on small scenes).
double lattice_capacity_steps() {
    double cap = lattice::kMaxCoord;
    if (const std::optional<double> steps = environment().max_lattice_steps) cap = std::clamp(*steps, 64.0, cap);
    return cap;
}

std::vector<CoarseCell> merge_cells(const std::vector<CoarseCell>& a, const std::vector<CoarseCell>& b) {
    std::vector<CoarseCell> out;
    out.reserve(a.size() + b.size());
    std::merge(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out),
               [](const CoarseCell& x, const CoarseCell& y) { return lattice::pack(x.coord) < lattice::pack(y.coord); });
    return out;
}

/// Unique fine points by level: all coordinates even = on the level-2 lattice. A pass over the
/// whole table, so in parallel (serial, it showed in the triangulation stage's time), on the
/// stored keys: a key's lowest bit of each axis tested at once, a loop the compiler vectorises.
void count_points(const FinePointMap& map, Stats& s) {
    using Counts = std::pair<std::size_t, std::size_t>;  // level 2, level 3
    const lattice::KeyLayout& layout = map.layout();
    const Counts c = map.with_keys([&](const auto* keys) {
        using Key = std::remove_cvref_t<decltype(*keys)>;
        const Key empty = Key(layout.empty()), lowest = Key(1) | (Key(1) << layout.y_shift) | (Key(1) << layout.z_shift);
        return tbb::parallel_reduce(
            tbb::blocked_range<std::size_t>(0, map.capacity(), 1 << 16), Counts{0, 0},
            [&](const tbb::blocked_range<std::size_t>& r, Counts c) {
                std::size_t stored = 0, even = 0;
                for (std::size_t slot = r.begin(); slot != r.end(); ++slot) {
                    const Key k = keys[slot];
                    stored += k != empty;
                    even += k != empty && (k & lowest) == 0;
                }
                return Counts{c.first + even, c.second + stored - even};
            },
            [](Counts a, Counts b) { return Counts{a.first + b.first, a.second + b.second}; });
    });
    s.fine_points_level2 = c.first;
    s.fine_points_level3 = c.second;
    s.fine_points = s.fine_points_level2 + s.fine_points_level3;
}

void count_mesh(const Mesh& m, Stats& s) {
    s.vertices = m.vertex_count();
    s.triangles = m.triangle_count();
    s.triangles_level2 = s.triangles_level3 = s.triangles_patch = 0;
    for (TriangleKind k : m.triangle_kind) {
        if (k == TriangleKind::Level2) ++s.triangles_level2;
        else if (k == TriangleKind::Level3) ++s.triangles_level3;
        else ++s.triangles_patch;
    }
}

/// What the level-2 check (host/level2_check.hpp) takes: which cells it checks, its tolerance in
/// world units (0: off) and the level history's factor on it per cell (empty: 1).
struct Level2Check {
    std::vector<std::uint8_t> checked;
    float tolerance = 0.0f;
    std::vector<float> scale;
};

/// The level-2 check (host/level2_check.hpp) on freshly evaluated cells and cube centres, before
/// continuity: the level-2 cells that fail it become level 3 and get their remaining points
/// (`table` is unmapped for that and mapped again). Returns how many.
std::size_t promote_failing_cells(OpenCLRuntime& rt, FinePoints& points, MappedFinePoints& table,
                                  std::vector<CoarseCell>& cells, const Level2Check& check,
                                  const LatticeFrame& lattice_frame, const BinnedParticles& bins, float r, float R) {
    std::vector<CoarseCell> promoted;
    for (std::size_t i :
         cells_failing_level2_check(cells, check.checked, lattice_frame, table.view, check.tolerance, check.scale)) {
        cells[i].level = 3;
        promoted.push_back(cells[i]);
    }
    if (!promoted.empty()) {
        table.unmap(rt);
        refine_and_evaluate(rt, points, promoted, lattice_frame, bins, r, R);
        table = map_fine_points(rt, points);
    }
    return promoted.size();
}

/// Stages 5-8 until the band is closed (docs/design.md §7): refine and evaluate the new cells, apply
/// transition continuity, find the faces the surface leaves through, add those neighbours and
/// repeat. Each round adds to the times of the stages "scalar_field" and "band_closure". Returns
/// the fine-point table mapped for the host; `cells` gains the added cells.
MappedFinePoints close_band(OpenCLRuntime& rt, FinePoints& points, std::vector<CoarseCell>& cells,
                            const LatticeFrame& lattice_frame, const BinnedParticles& bins, float r, float R,
                            const Level2Check& level2, Stats& s) {
    std::vector<CoarseCell> fresh = cells;
    const std::vector<std::uint8_t> no_centres;
    for (bool first = true;; first = false) {
        MappedFinePoints table;
        {
            StageScope stage(s, "scalar_field", rt);
            const bool check = first && level2.tolerance > 0.0f;  // the cube centres join the first pass
            refine_and_evaluate(rt, points, fresh, lattice_frame, bins, r, R, check ? level2.checked : no_centres);
            table = map_fine_points(rt, points);
            if (check)
                s.level2_check_cells = promote_failing_cells(rt, points, table, cells, level2, lattice_frame, bins, r, R);
        }
        {
            StageScope stage(s, "band_closure", rt);
            const CellIndex index(cells);  // both read the same cells
            apply_transition_continuity(cells, index, lattice_frame, table.view);
            fresh = band_closure_cells(cells, index, lattice_frame, table.view);
        }
        if (fresh.empty()) return table;
        table.unmap(rt);
        s.band_closure_cells += fresh.size();
        cells = merge_cells(cells, fresh);
    }
}

/// A smoothed mesh gets area-weighted normals for NormalMode::Gradient: its vertices left the field's zero set.
bool gradient_normals_wanted(const Params& p) { return p.normals == NormalMode::Gradient && !p.smooth; }

/// Whether a stage after the mesh reads the particles on the host: gradient normals, smoothing
/// weights, attributes. (Area normals read only the mesh.)
bool reads_particles_later(const Params& p, bool attributes) { return gradient_normals_wanted(p) || p.smooth || attributes; }

/// The frame's one particle grid (core/particle_grid.hpp) for the stages after the mesh that read
/// the particles (smoothing weights, gradient normals, attributes): built by the first of them,
/// timed with it, shared by the others.
class FrameGrid {
public:
    FrameGrid(const float* xyz, std::size_t n, const Params& p) : xyz_(xyz), n_(n), p_(p) {}
    /// Another frame's particles (the grid, if built, is dropped).
    void use(const float* xyz, std::size_t n) {
        xyz_ = xyz;
        n_ = n;
        grid_.reset();
    }
    const ParticleGrid& get() {
        if (!grid_) grid_.emplace(vertex_particle_grid(xyz_, n_, p_.particle_radius, p_.kernel_radius * p_.particle_radius));
        return *grid_;
    }
    void release() { grid_.reset(); }

private:
    const float* xyz_;
    std::size_t n_;
    const Params& p_;
    std::optional<ParticleGrid> grid_;
};

/// The smoothing weights of the vertices at `positions` (host/mesh_smoothing.hpp) from the frame's
/// grid, which is released after them unless `keep_grid` (the vertex stages read it later).
std::vector<float> frame_weights(const std::vector<float>& positions, FrameGrid& grid, bool keep_grid, const Params& p) {
    std::vector<float> w = smoothing_weights(positions, grid.get(), p.particle_radius, p.kernel_radius * p.particle_radius);
    if (!keep_grid) grid.release();  // freed before the smoothing's own arrays
    return w;
}

/// Whether post-processing changes the mesh (and then checks it for closedness itself).
bool postprocessed(const Params& p) { return p.smooth || p.sliver_cleanup; }

/// Post-processing for rendering, in world units: sliver cleanup, then smoothing (Params::smooth,
/// host/sliver_cleanup.hpp, host/mesh_smoothing.hpp), each timed when asked for. The grid is
/// released after the weights unless `keep_grid` (the vertex stages read it later).
void postprocess(Mesh& mesh, FrameGrid& grid, bool keep_grid, const Params& p, Stats& s, std::vector<float>&& early_weights) {
    if (!postprocessed(p)) return;
    std::vector<float> weights;
    {
        // With smoothing, the weights read only the vertex positions, which no collapse moves (it
        // keeps one end where it is), so the weights of the vertices left carry over. They come
        // computed beside the crack collapse (`early_weights`, one per vertex now), or else are
        // computed beside this cleanup (serial) on the other host threads; the stage's time is then
        // that of both.
        StageScope stage(s, "sliver_cleanup");
        if (!p.smooth) {
            s.sliver_edges_collapsed = collapse_slivers(mesh);
        } else {
            std::vector<std::uint32_t> kept;
            auto cleanup = [&] { s.sliver_edges_collapsed = collapse_slivers(mesh, &kept); };
            if (early_weights.size() != mesh.vertex_count()) {
                const std::vector<float> before = mesh.positions;  // a copy: the cleanup compacts them
                run_beside([&] { early_weights = frame_weights(before, grid, keep_grid, p); }, cleanup);
            } else {
                cleanup();
            }
            weights = kept_values(early_weights, kept);
        }
    }
    if (p.smooth) {
        StageScope stage(s, "smoothing");
        SmoothingSettings settings;
        settings.iterations = p.smooth_iterations > 0 ? p.smooth_iterations : kDefaultSmoothIterations;
        settings.min_volume = smooth_min_volume(p.particle_radius);
        s.smoothing_reverted_moves = smooth_mesh(mesh, weights, settings).reverted_moves;
    }
    count_mesh(mesh, s);
    s.closed = is_closed_and_oriented(mesh);
}

/// Stage 11 (host/vertex_data.hpp): normals and attributes at the vertices, each timed when asked for.
void add_vertex_data(Mesh& mesh, FrameGrid& grid, const float* xyz, std::size_t n, const Params& p,
                     const std::vector<ParticleAttribute>& attributes, Stats& s) {
    if (p.normals == NormalMode::None && attributes.empty()) return;
    const float r = p.particle_radius, R = p.kernel_radius * r;
    if (p.normals != NormalMode::None) {
        StageScope stage(s, "normals");
        mesh.normals = area_weighted_normals(mesh);
        if (gradient_normals_wanted(p)) mesh.normals = gradient_normals(mesh, grid.get(), r, R, mesh.normals);
    }
    if (!attributes.empty()) {
        StageScope stage(s, "attributes");
        mesh.attributes = interpolate_attributes(mesh, grid.get(), xyz, n, R, attributes);
    }
}

/// Params::remove_components_below on the finished mesh (world units).
void remove_components(Mesh& m, const Params& p, Stats& s) {
    StageScope stage(s, "remove_components");
    const double volume = double(p.remove_components_below) * std::pow(2.0 * double(p.particle_radius), 3.0);
    s.components_removed = remove_small_components(m, volume);
    if (s.components_removed) count_mesh(m, s);
}

/// Params::clip_box, the last change of the mesh: cut at the box and closed there.
void clip_to_box(Mesh& m, const Params& p, Stats& s) {
    StageScope stage(s, "clip_box");
    s.clip_cap_triangles = clip_mesh_to_box(m, *p.clip_box, p.particle_radius).cap_triangles;
    count_mesh(m, s);
    s.closed = is_closed_and_oriented(m);
}

std::uint64_t peak_rss_bytes() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return std::uint64_t(u.ru_maxrss) * 1024;
}

/// Whether two parameter sets give the same lattice and the same curvature, so that the levels
/// of one frame are comparable with those of the next.
bool levels_comparable(const Params& a, const Params& b) {
    return a.particle_radius == b.particle_radius && a.kernel_radius == b.kernel_radius && a.mode == b.mode &&
           a.cell == b.cell;
}

}  // namespace

namespace {

/// The checks of a frame before any work: parameters, particle count, attributes.
void validate_frame(const Params& p, std::size_t count, const std::vector<ParticleAttribute>& attributes) {
    check_params(p);
    if (count == 0) throw Error("no particles to reconstruct (the input is empty)");
    if (count > std::numeric_limits<std::uint32_t>::max() / 2) throw Error("too many particles for one frame");
    validate_attributes(attributes, count);
}

}  // namespace

/// A frame after its mesh: what reconstruct() does on the host alone (post-processing, normals,
/// attributes, the frame's totals), kept apart so that FramePipeline can run it on another thread
/// while the Reconstructor meshes the next frame. It reads only what it holds: the positions (its
/// own or the caller's), the attributes, the frame's particle grid and the mesh.
struct FrameTail {
    FrameTail(const Params& params, Stats& stats) : p(params), s(stats), grid(nullptr, 0, p) {}
    FrameTail(const FrameTail&) = delete;
    FrameTail& operator=(const FrameTail&) = delete;

    /// The particles: `xyz` points into own_xyz or at the caller's array.
    void set_particles(const float* positions, std::size_t n) {
        xyz = positions;
        count = n;
        grid.use(xyz, count);
    }

    /// Post-processing, normals and attributes: world units, after any scaling or split.
    Mesh finish() {
        try {
            if (triangulate) {  // deferred by the Reconstructor (Reconstructor::Impl::defer_triangulation)
                const std::function<Mesh()> f = std::move(triangulate);
                triangulate = nullptr;
                mesh = f();
            }
            const bool carried = crack_kept.size() == mesh.vertex_count() && !early_weights.empty();
            early_weights = carried ? kept_values(early_weights, crack_kept) : std::vector<float>{};
            std::vector<std::uint32_t>().swap(crack_kept);
            if (p.remove_components_below > 0.0f) remove_components(mesh, p, s);
            if (s.components_removed) early_weights.clear();  // renumbered: computed again after
            postprocess(mesh, grid, keep_grid, p, s, std::move(early_weights));
            if (p.clip_box) clip_to_box(mesh, p, s);  // last: every vertex ends in the box
            add_vertex_data(mesh, grid, xyz, count, p, *attributes, s);
        } catch (const std::bad_alloc&) {
            throw Error("out of host memory during reconstruction; use a larger cell, a smaller domain or --memory-limit");
        }
        s.time_ms.emplace_back("total", std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        // Program builds first: the constructor's, and any on demand during this frame.
        if (loaded_ms >= 0) s.time_ms.insert(s.time_ms.begin(), {"kernel_load", loaded_ms});
        if (compiled_ms >= 0) s.time_ms.insert(s.time_ms.begin(), {"kernel_compile", compiled_ms});
        if (box_all) {  // Params::particle_box: counted over every particle given
            s.particles = *box_all;
            s.particles_outside_box = *box_all - count;
        }
        return std::move(mesh);
    }

    const Params p;  ///< without particle_box (applied before)
    Stats& s;
    std::vector<float> own_xyz;
    std::vector<ParticleAttribute> own_attributes;
    const float* xyz = nullptr;
    std::size_t count = 0;
    const std::vector<ParticleAttribute>* attributes = &own_attributes;
    std::optional<std::size_t> box_all;  ///< the particles before Params::particle_box took its own
    FrameGrid grid;  ///< built by the first stage that reads the particles
    bool keep_grid = false;
    std::vector<float> early_weights;       ///< the smoothing weights computed beside the crack collapse
    std::vector<std::uint32_t> crack_kept;  ///< the old index of each vertex the crack collapse left
    /// Where the Reconstructor deferred the triangulation (FramePipeline): makes `mesh`, on the
    /// thread that calls finish().
    std::function<Mesh()> triangulate;
    Mesh mesh;
    Clock::time_point t0 = Clock::now();
    double compiled_ms = -1.0, loaded_ms = -1.0;
};

struct Reconstructor::Impl {
    Impl(int device, std::function<void(const KernelCompileNotice&)> on_compile) : rt(device, std::move(on_compile)) {}
    Impl(cl_context c, cl_device_id d, cl_command_queue q) : rt(c, d, q) {}
    OpenCLRuntime rt;
    /// The caller's buffer during reconstruct(DevicePositions) (the `xyz` of mesh_in_float_range()
    /// is null then).
    std::optional<DeviceInput> device_in;
    std::vector<float> read_back;  ///< its copy where the device path cannot be taken (mesh_in_float_range())
    LevelHistory history;  ///< levels of the previous frame (adaptive mode)
    /// Positions handed over by reconstruct(std::vector<float>&&), freed once run_stages() has
    /// uploaded them (null: none, or normals or attributes read them later).
    std::vector<float>* handed_over = nullptr;
    Params history_params;
    LatticePhase history_phase{};  ///< the lattice phase of the frames in `history`
    float user_radius = 0.0f;  ///< the radius as given, for messages (the pipeline may run scaled)
    /// Set by reconstruct() for a frame whose post-processing reads per-vertex data of the
    /// particles (smoothing weights) and whose mesh comes from one unscaled lattice: called with
    /// the vertex positions (world units) before the crack collapse, beside it (run_stages(),
    /// triangulate_cells()); crack_kept then holds the old index of each vertex the collapse left.
    std::function<void(const std::vector<float>&)> beside_crack_collapse;
    std::vector<std::uint32_t> crack_kept;
    /// The frame whose triangulation run_stages() leaves to its tail (FrameTail::triangulate): set
    /// by mesh_frame() where asked (FramePipeline) and the mesh is unscaled; run_stages() takes it
    /// only for a whole frame's lattice (keep_levels), not a split domain's groups.
    FrameTail* defer_into = nullptr;

    // A frame's mesh, before post-processing, in three steps, each calling the next:
    /// Checks the radius against the particles and scales the lengths into the range the float
    /// kernels handle (length_scale_exponent), then mesh_domain().
    Mesh mesh_in_float_range(const float* xyz, std::size_t n, const Params& p, Stats& s);
    /// The particles on one lattice, or split into far-apart groups on a lattice each when they do
    /// not fit one (domain_split.hpp), each through run_stages().
    Mesh mesh_domain(const float* xyz, std::size_t n, const Params& p, Stats& s, const Bounds& b);
    /// The pipeline's stages on one lattice: binning to triangulation (docs/design.md §2).
    /// `keep_levels`: record this frame's levels for the next one (off for the groups of a split
    /// domain, each on a lattice of its own).
    Mesh run_stages(const float* xyz, std::size_t n, const Params& p, const Grid& g, Stats& s, bool keep_levels = true);
    void remember_levels(const std::vector<CoarseCell>& cells, const Grid& g, const Params& p, Stats& s);
    /// The lattice phase of a frame: the level history's while it lasts (its cells are those of one
    /// lattice), else `own()` (lattice_phase_for the frame's particles).
    template <class Own>
    LatticePhase phase_for(const Params& p, Own&& own) const {
        if (!history.empty() && levels_comparable(history_params, p)) return history_phase;
        return own();
    }
    /// run_stages()' end for a deferred triangulation: the fine-point table copied to the host and
    /// the device's buffers given back, the frame's levels and device figures recorded now (the
    /// next frame's stages need the levels), and the triangulation left to `t`, which then reads
    /// nothing of this Reconstructor (it may be meshing the next frame meanwhile).
    void defer_triangulation(FrameTail& t, std::vector<CoarseCell>&& cells, const Grid& g, const Params& p,
                             MappedFinePoints& table, FinePoints& points, Stats& s);
    /// reconstruct() up to the mesh, into t.mesh: checks, device stages, triangulation (the
    /// smoothing weights beside the crack collapse when t's post-processing needs them), the
    /// triangulation left to t.triangulate with `defer_triangulation` where the mesh comes from
    /// one unscaled lattice.
    void mesh_frame(FrameTail& t, bool defer_triangulation = false);
    /// reconstruct(std::vector<float>&&)'s stages up to the mesh, with the positions held by the
    /// returned tail (Params::particle_box applied to them first). The attributes are read where
    /// they are, or taken over from `take` where given (FramePipeline), or copied where the box
    /// filters them.
    std::shared_ptr<FrameTail> mesh_owned(std::vector<float>&& xyz, const Params& params, Stats& stats,
                                          const std::vector<ParticleAttribute>& attributes,
                                          std::vector<ParticleAttribute>* take, bool defer_triangulation = false);
    /// Frees the handed-over positions once copied or uploaded, when `xyz` are they (a split
    /// domain's groups are copies, and its later groups still read the original).
    void release_input(const float* xyz) {
        if (!handed_over || handed_over->data() != xyz) return;
        std::vector<float>().swap(*handed_over);
        handed_over = nullptr;
    }
};

namespace {

/// Host memory a reconstruction may use: the memory limit, else what the kernel says is available.
std::uint64_t host_budget(const Params& p) {
    const std::uint64_t avail = available_ram();
    if (p.memory_limit_bytes) return avail ? std::min(avail, p.memory_limit_bytes) : p.memory_limit_bytes;
    return avail;  // 0: unknown, no check
}

/// Fails before a large host allocation that would not fit the budget (docs/design.md §4);
/// `advice` ends the message.
void check_host(double bytes, double budget, const std::string& what,
                const std::string& advice = "use a larger cell or a smaller domain") {
    if (budget > 0 && bytes > budget)
        throw Error(what + " needs ~" + io::byte_size_text(std::uint64_t(bytes)) + " of host memory, over the budget of " +
                    io::byte_size_text(std::uint64_t(budget)) + " (--memory-limit or the available RAM); " + advice);
}

/// Stage "triangulation" of a frame's cells (the caller times it): the cell and point counts, the
/// check against `host_bytes` of host memory, then triangulate_cells() (surface_mesher.hpp), whose hooks it passes on.
Mesh triangulate_frame(const std::vector<CoarseCell>& cells, const LatticeFrame& lattice, const FinePointMap& field,
                       const Params& p, double host_bytes, Stats& s,
                       const std::function<void(const std::vector<float>&)>& beside_collapse,
                       std::vector<std::uint32_t>* kept, const std::function<void()>& field_done) {
    s.surface_cells = cells.size();
    for (const auto& c : cells) (c.level == 2 ? s.surface_cells_level2 : s.surface_cells_level3)++;
    count_points(field, s);
    check_host(double(s.fine_points) * constants::kMeshBytesPerFinePoint, host_bytes,
               "the mesh of " + std::to_string(s.fine_points) + " fine points");
    return triangulate_cells(cells, lattice, field, p.crack_closing, &s.crack_vertices_collapsed, beside_collapse, kept,
                             field_done);
}

/// The mesh's counts and, where no post-processing changes it afterwards (it checks the mesh
/// itself then), whether the mesh is closed.
void count_mesh_and_check(const Mesh& mesh, const Params& p, Stats& s) {
    count_mesh(mesh, s);
    if (!postprocessed(p)) s.closed = is_closed_and_oriented(mesh);
}

/// Adds the counts and times of one group's reconstruction to the frame's (split domains).
void accumulate(Stats& into, const Stats& s) {
    into.surface_particles += s.surface_particles;
    into.splash_particles += s.splash_particles;
    into.surface_cells += s.surface_cells;
    into.surface_cells_level2 += s.surface_cells_level2;
    into.surface_cells_level3 += s.surface_cells_level3;
    into.splash_cells += s.splash_cells;
    into.isolated_piece_cells += s.isolated_piece_cells;
    into.band_closure_cells += s.band_closure_cells;
    into.level2_check_cells += s.level2_check_cells;
    into.fine_points += s.fine_points;
    into.fine_points_level2 += s.fine_points_level2;
    into.fine_points_level3 += s.fine_points_level3;
    into.crack_vertices_collapsed += s.crack_vertices_collapsed;
    into.device_memory_bytes = std::max(into.device_memory_bytes, s.device_memory_bytes);
    into.device = s.device;
    into.device_compute_units = s.device_compute_units;
    into.host_threads = s.host_threads;
    auto add = [](auto& list, const auto& more) {
        for (const auto& [name, ms] : more) {
            auto it = std::find_if(list.begin(), list.end(), [&](const auto& e) { return e.first == name; });
            if (it == list.end()) list.emplace_back(name, ms);
            else it->second += ms;
        }
    };
    add(into.time_ms, s.time_ms);
    add(into.kernel_ms, s.kernel_ms);
}

void append(Mesh& into, Mesh&& m) {
    if (into.positions.empty()) {
        into = std::move(m);
        return;
    }
    const auto base = std::uint32_t(into.vertex_count());
    into.positions.insert(into.positions.end(), m.positions.begin(), m.positions.end());
    for (std::uint32_t v : m.triangles) into.triangles.push_back(v + base);
    into.vertex_level.insert(into.vertex_level.end(), m.vertex_level.begin(), m.vertex_level.end());
    into.triangle_kind.insert(into.triangle_kind.end(), m.triangle_kind.begin(), m.triangle_kind.end());
}

}  // namespace

/// Runs the pipeline on radius-normalised lengths when the radius is outside the band the float
/// kernels handle (length_scale_exponent): scaling by a power of two is exact.
Mesh Reconstructor::Impl::mesh_in_float_range(const float* xyz, std::size_t n, const Params& p, Stats& s) {
    if (device_in) {  // a caller's buffer: bounds and binning input on the device (device_input.hpp)
        rt.set_stage("binning");  // named for errors; run_stages() times the binning stage
        const Bounds b = device_bounds(rt, *device_in);
        validate_against(p, b);
        user_radius = p.particle_radius;
        if (rt.has_fp64() && length_scale_exponent(p.particle_radius) == 0) {
            const LatticePhase phase = phase_for(p, [&] {
                const std::vector<float> sample = read_device_sample(rt, *device_in, phase_sample_step(n));
                return lattice_phase_of(sample.data(), sample.size() / 3, 1, p.particle_radius);
            });
            const Grid g = make_grid(p, b, phase);
            if (g.extent_steps <= lattice_capacity_steps()) return run_stages(nullptr, n, p, g, s);
        }
        read_back = read_device_positions(rt, *device_in);  // scaled or split on the host
        device_in.reset();
        return mesh_in_float_range(read_back.data(), n, p, s);
    }
    const Bounds b = bounds_of(xyz, n);
    validate_against(p, b);
    user_radius = p.particle_radius;
    const int k = length_scale_exponent(p.particle_radius);
    if (k == 0) return mesh_domain(xyz, n, p, s, b);
    check_host(double(n) * 12, double(host_budget(p)), "a scaled copy of " + std::to_string(n) + " particles");
    std::vector<float> scaled(xyz, xyz + 3 * n);
    release_input(xyz);
    for (float& v : scaled) v = std::ldexp(v, k);
    Params q = p;
    q.particle_radius = std::ldexp(p.particle_radius, k);
    Mesh m = mesh_domain(scaled.data(), n, q, s, bounds_of(scaled.data(), n));
    for (float& v : m.positions) v = std::ldexp(v, -k);
    return m;
}

/// One lattice when the particles fit it; otherwise groups of far-apart clusters, each on a
/// lattice of its own, their meshes concatenated (domain_split.hpp).
Mesh Reconstructor::Impl::mesh_domain(const float* xyz, std::size_t n, const Params& p, Stats& s, const Bounds& b) {
    const double capacity = lattice_capacity_steps();
    const Grid g = make_grid(p, b, phase_for(p, [&] { return lattice_phase_for(xyz, n, p.particle_radius); }));
    if (g.extent_steps <= capacity) return run_stages(xyz, n, p, g, s);

    const double R = double(p.kernel_radius) * p.particle_radius, edge = g.coarse_edge;
    // A particle reaches R with its neighbour sums, its surface cells lie within R + one coarse
    // cell, band closure adds one more, and levels look one 3x3x3 block (and its neighbours) further.
    const double separation = 2.0 * (R + 3.0 * edge);
    const double margin = 6.0 * g.lattice.coarse_steps;  // make_grid's lattice margin, in steps
    const double tile = 0.5 * (capacity - margin - 2.0 * g.lattice.coarse_steps) * g.lattice.step;
    const auto groups = split_domain(xyz, n, separation, tile);
    Mesh mesh;
    std::vector<float> part;
    bool closed = true;  // the groups' meshes share no vertex: the union is closed when each is
    history.reset();  // each group has a lattice of its own: no level history across them or frames
    for (const auto& members : groups) {
        part.resize(3 * members.size());
        for (std::size_t i = 0; i < members.size(); ++i)
            for (int a = 0; a < 3; ++a) part[3 * i + a] = xyz[3 * std::size_t(members[i]) + a];
        const Grid gg = make_grid(p, bounds_of(part.data(), members.size()),
                                  lattice_phase_for(part.data(), members.size(), p.particle_radius));
        if (gg.extent_steps > capacity)  // split_domain keeps every group within one lattice
            throw Error("internal: a particle group of " + std::to_string(members.size()) + " does not fit one lattice");
        Stats gs;
        append(mesh, run_stages(part.data(), members.size(), p, gg, gs, false));
        accumulate(s, gs);
        closed = closed && gs.closed;
    }
    s.particles = n;
    count_mesh(mesh, s);
    s.closed = closed;
    s.peak_memory_bytes = peak_rss_bytes();
    return mesh;
}

Mesh Reconstructor::Impl::run_stages(const float* xyz, std::size_t n, const Params& p, const Grid& g, Stats& s,
                                     bool keep_levels) {
    const float r = p.particle_radius, R = p.kernel_radius * r;
    const float threshold = p.curvature_threshold > 0.0f ? p.curvature_threshold : default_curvature_threshold();
    const double host = double(host_budget(p));
    s.particles = n;
    s.device = rt.info().name;
    s.device_compute_units = rt.info().compute_units;
    s.host_threads = unsigned(std::min<std::size_t>(std::size_t(tbb::this_task_arena::max_concurrency()),
                                                   tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
    rt.reset_budget(p.memory_limit_bytes);

    BinnedParticles bins;
    {
        StageScope stage(s, "binning", rt);
        check_host(double(n) * sizeof(glm::vec4), host, "uploading " + std::to_string(n) + " particles");
        // Neighbour sums cost sum(count^2) over bins of edge R; at a rest spacing of 2r a bin holds
        // (K/2)^3 particles. Far more means every particle sees thousands of others: a radius far too
        // large, or a pile of particles, that would run for hours instead of failing. Checked once
        // the bins are counted, before the particles are sorted into them (PairLoadCheck).
        const double rest = std::pow(0.5 * p.kernel_radius, 3.0);
        auto check_load = [&](std::uint64_t pair_load) {
            if (double(pair_load) > std::max(double(1u << 28), 64.0 * rest * double(n)))
                throw Error("particle radius " + fmt(user_radius) + ": on average each particle has " +
                            fmt(double(pair_load) / double(n)) + " others within one kernel radius (about " + fmt(rest) +
                            " at a rest spacing of 2r), too many to sum; the radius is probably too large for these particles");
        };
        bins = device_in ? bin_device_positions(rt, *device_in, g.origin, R, check_load)
                         : bin_particles(rt, xyz, n, g.origin, R, [&] { release_input(xyz); }, check_load);
        bins.order = DeviceBuffer{};  // sorted -> input index: only the tests read it
    }
    ParticleClasses classes;
    {
        StageScope stage(s, "surface_particles", rt);
        classes = classify_particles(rt, bins, r, R);
        s.surface_particles = classes.surface;
        s.splash_particles = classes.splash;
        // A radius far too small for its particles leaves them apart: each is meshed as a droplet of
        // its own, on the r lattice. Millions of them run for minutes before the memory for their
        // fine points fails; this fails at once and names the likely cause.
        if (classes.splash > n / 2)
            check_host(double(classes.splash) * constants::kBytesPerLoneParticle, host,
                       "meshing " + std::to_string(classes.splash) + " of " + std::to_string(n) + " particles with fewer than " +
                           std::to_string(constants::kSplashNeighbours) + " others within the kernel radius as a droplet each",
                       "the particle radius " + fmt(user_radius) + " is probably too small for these particles (their rest spacing is 2r)");
    }
    SurfaceCells sc;
    std::vector<std::uint8_t> previous;  // the previous frame's level of each cell (hysteresis; empty: none)
    {
        StageScope stage(s, "surface_cells", rt);
        sc = surface_cells(rt, bins, classes, r, R, g.coarse_edge, threshold, g.forced_level);
        for (std::uint8_t f : sc.splash) s.splash_cells += f;
        if (!history.empty() && !levels_comparable(history_params, p)) history.reset();
        if (g.forced_level == 0) {
            if (p.level_hysteresis > 0.0f) previous = history.previous_levels(sc.cells, g.coarse_base);
            // Paper Fig. 1: isolated pieces (small droplets) are level 3, whatever their curvature.
            s.isolated_piece_cells = promote_isolated_pieces(sc.cells, sc.splash, constants::kIsolatedPieceCells, previous,
                                                             p.level_hysteresis);
            s.level_held = LevelHistory::apply(sc.cells, sc.curvature, sc.splash, previous, threshold, p.level_hysteresis);
        }
        classes = ParticleClasses{};  // memory follows the surface from here on (docs/design.md §4)
    }

    std::vector<CoarseCell> cells = sc.cells;
    Mesh mesh;
    if (!cells.empty()) {  // particles without surface (none can be: a safety net) give an empty mesh
        Level2Check level2;  // the check's second opinion, where the curvature is not clearly flat
        level2.tolerance = g.forced_level == 0 ? p.level2_tolerance * r : 0.0f;
        if (level2.tolerance > 0.0f) {
            level2.scale = LevelHistory::check_scale(previous, p.level_hysteresis);  // empty: no history
            // Cells of thin bodies (rods, sheets, droplets: no particle inside the fluid in their
            // 3x3x3 block) are checked whatever their curvature, at a tighter tolerance. Over a
            // sequence a cell that was level 3 is checked so too: a droplet touching the pool
            // would otherwise drop out of the rule and flip back to level 2.
            for (std::size_t i = 0; i < sc.cells.size(); ++i) {
                const bool thin = sc.thin_body[i] || (!previous.empty() && previous[i] == 3);
                level2.checked.push_back(thin || sc.curvature[i] >= constants::kLevel2CheckCurvature);
                if (!thin) continue;
                if (level2.scale.empty()) level2.scale.assign(sc.cells.size(), 1.0f);
                level2.scale[i] *= constants::kThinBodyTolerance;
            }
        }
        FinePoints points;
        // Stages "scalar_field" and "band_closure", repeated until the band is closed.
        MappedFinePoints table = close_band(rt, points, cells, g.lattice, bins, r, R, level2, s);
        {
            // Edge refinement (reference: tests/reference/edge_refinement.hpp): true values at the
            // midpoints of crossed level-2 edges, found, inserted and evaluated on the device. Continuity never touches
            // these points (no level-3 cell holds them), and the values it wrote stay in the table
            // (a rehash copies them).
            StageScope stage(s, "edge_refinement", rt);
            table.unmap(rt);
            refine_edges(rt, points, cells, g.lattice, bins, r, R);
            table = map_fine_points(rt, points);
            bins = BinnedParticles{};
        }
        if (defer_into && keep_levels) {  // FramePipeline: triangulation later, on the tail's thread
            defer_triangulation(*defer_into, std::move(cells), g, p, table, points, s);
            return Mesh{};
        }
        {
            StageScope stage(s, "triangulation", rt);
            const bool beside = keep_levels && beside_crack_collapse;  // one lattice: its mesh is the frame's
            // The table is given back once the cells are meshed, before the crack collapse builds its
            // crossing grid (a first frame's pool frees it then): x64's peak was both at once.
            auto release_table = [&] {
                table.unmap(rt);
                points = FinePoints{};
                rt.set_stage("");
            };
            mesh = triangulate_frame(cells, g.lattice, table.view, p, host, s, beside ? beside_crack_collapse : nullptr,
                                     beside ? &crack_kept : nullptr, release_table);
        }
    }
    count_mesh_and_check(mesh, p, s);
    if (keep_levels) remember_levels(cells, g, p, s);
    for (auto& [name, ms] : rt.take_kernel_times()) s.kernel_ms.emplace_back(name, ms);
    rt.set_stage("");
    s.peak_memory_bytes = peak_rss_bytes();
    s.device_memory_bytes = rt.peak_lent_bytes();
    return mesh;
}

void Reconstructor::Impl::defer_triangulation(FrameTail& t, std::vector<CoarseCell>&& cells, const Grid& g,
                                              const Params& p, MappedFinePoints& table, FinePoints& points, Stats& s) {
    FinePointMap field = FinePointMap::copy_of(table.view);  // 8 bytes a slot with 32-bit keys
    table.unmap(rt);
    points = FinePoints{};
    remember_levels(cells, g, p, s);
    for (auto& [name, ms] : rt.take_kernel_times()) s.kernel_ms.emplace_back(name, ms);
    rt.set_stage("");
    s.device_memory_bytes = rt.peak_lent_bytes();
    // run_stages()' "triangulation" on what the closure holds; the smoothing weights' hook and the
    // collapse's kept vertices go straight to the tail.
    t.triangulate = [&t, &s, cells = std::move(cells), lattice = g.lattice, field = std::move(field),
                     beside = beside_crack_collapse]() mutable {
        Mesh mesh;
        {
            StageScope stage(s, "triangulation");
            mesh = triangulate_frame(cells, lattice, field, t.p, double(host_budget(t.p)), s, beside,
                                     beside ? &t.crack_kept : nullptr, [&] { field = FinePointMap{}; });
        }
        count_mesh_and_check(mesh, t.p, s);
        s.peak_memory_bytes = peak_rss_bytes();
        return mesh;
    };
}

/// Counts the flips against the previous frame and keeps this frame's levels (adaptive mode;
/// uniform modes have no levels to keep coherent).
void Reconstructor::Impl::remember_levels(const std::vector<CoarseCell>& cells, const Grid& g, const Params& p, Stats& s) {
    if (g.forced_level != 0) {
        history.reset();
        return;
    }
    if (!history.empty()) {
        const LevelHistory::Flips f = history.compare(cells, g.coarse_base);
        s.level_history = true;
        s.level_cells_compared = f.compared;
        s.level_flips = f.changed;
    }
    history.record(cells, g.coarse_base);
    history_params = p;
    history_phase = g.phase;
}

Reconstructor::Reconstructor(int device, std::function<void(const KernelCompileNotice&)> on_compile)
    : impl_(std::make_unique<Impl>(device, std::move(on_compile))) {}
Reconstructor::Reconstructor(_cl_context* context, _cl_device_id* device, _cl_command_queue* queue)
    : impl_(std::make_unique<Impl>(context, device, queue)) {}
Reconstructor::~Reconstructor() = default;
Reconstructor::Reconstructor(Reconstructor&&) noexcept = default;
Reconstructor& Reconstructor::operator=(Reconstructor&&) noexcept = default;
const DeviceInfo& Reconstructor::device() const { return impl_->rt.info(); }
void Reconstructor::reset_history() { impl_->history.reset(); }

Mesh Reconstructor::reconstruct(const float* xyz, std::size_t count, const Params& params, Stats* stats) {
    return reconstruct(xyz, count, params, stats, {});
}

Mesh Reconstructor::reconstruct(const DevicePositions& d, const Params& params, Stats* stats) {
    OpenCLRuntime& rt = impl_->rt;
    if (d.count == 0) throw Error("no particles to reconstruct (the input is empty)");
    std::vector<float> host;  // the positions, where the device path cannot be taken
    try {
        DeviceInput in = device_input(rt, d.buffer, d.count, d.offset, d.stride);
        if (!d.wait_for.empty()) {
            std::vector<cl::Event> events;
            for (_cl_event* e : d.wait_for) events.emplace_back(e, true);
            rt.queue().enqueueBarrierWithWaitList(&events);
        }
        if (!reads_particles_later(params, false)) {
            impl_->device_in = std::move(in);
        } else {
            host = read_device_positions(rt, in);
        }
    } catch (const cl::Error& e) {
        rt.recover();
        throw Error(std::string("OpenCL failure reading the device positions: ") + e.what() + " returned " +
                    cl_error_name(e.err()) + cl_error_advice(e.err()));
    }
    if (!impl_->device_in) return reconstruct(std::move(host), params, stats);
    struct Forget {  // whatever happens, the Impl keeps neither the caller's buffer nor its copy
        Impl& impl;
        ~Forget() {
            impl.device_in.reset();
            std::vector<float>().swap(impl.read_back);
        }
    } forget{*impl_};
    return reconstruct(static_cast<const float*>(nullptr), d.count, params, stats, {});
}

Mesh Reconstructor::reconstruct(std::vector<float>&& xyz, const Params& params, Stats* stats,
                                const std::vector<ParticleAttribute>& attributes) {
    Stats local;
    return impl_->mesh_owned(std::move(xyz), params, stats ? *stats : local, attributes, nullptr)->finish();
}

std::function<Mesh()> Reconstructor::mesh_then_finish(std::vector<float>&& xyz, const Params& params, Stats& stats,
                                                      std::vector<ParticleAttribute> attributes, bool defer_triangulation) {
    std::shared_ptr<FrameTail> t =
        impl_->mesh_owned(std::move(xyz), params, stats, attributes, &attributes, defer_triangulation);
    return [t] { return t->finish(); };
}

std::shared_ptr<FrameTail> Reconstructor::Impl::mesh_owned(std::vector<float>&& xyz, const Params& params, Stats& stats,
                                                           const std::vector<ParticleAttribute>& attributes,
                                                           std::vector<ParticleAttribute>* take, bool defer_triangulation) {
    if (xyz.size() % 3 != 0)
        throw Error("positions: " + std::to_string(xyz.size()) + " floats are not x, y, z triplets");
    Params q = params;
    q.particle_box.reset();
    auto t = std::make_shared<FrameTail>(q, stats);
    t->own_xyz = std::move(xyz);
    if (take) t->own_attributes = std::move(*take);
    else t->attributes = &attributes;  // read where they are
    if (params.particle_box) {  // filtered in place (the attributes: a copy); the rest runs on the particles inside
        validate_frame(params, t->own_xyz.size() / 3, *t->attributes);  // before the filter
        if (t->attributes != &t->own_attributes) {
            t->own_attributes = *t->attributes;
            t->attributes = &t->own_attributes;
        }
        t->box_all = t->own_xyz.size() / 3;
        if (*t->box_all) keep_particles_in_box(t->own_xyz, t->own_attributes, *params.particle_box);
    }
    t->set_particles(t->own_xyz.data(), t->own_xyz.size() / 3);
    handed_over = reads_particles_later(q, !t->attributes->empty()) ? nullptr : &t->own_xyz;
    struct Forget {  // whatever happens, the Impl does not keep a pointer to this frame's vector
        Impl& impl;
        ~Forget() { impl.handed_over = nullptr; }
    } forget{*this};
    mesh_frame(*t, defer_triangulation);
    return t;
}

Mesh Reconstructor::reconstruct(const float* xyz, std::size_t count, const Params& params, Stats* stats,
                                const std::vector<ParticleAttribute>& attributes) {
    if (params.particle_box) {
        validate_frame(params, count, attributes);  // before the copy
        return reconstruct(std::vector<float>(xyz, xyz + 3 * count), params, stats, attributes);
    }
    Stats local;
    FrameTail t(params, stats ? *stats : local);
    t.set_particles(xyz, count);
    t.attributes = &attributes;
    impl_->mesh_frame(t);
    return t.finish();
}

void Reconstructor::Impl::mesh_frame(FrameTail& t, bool defer_triangulation) {
    const float* xyz = t.xyz;
    const std::size_t count = t.count;
    const Params& params = t.p;
    validate_frame(params, count, *t.attributes);
    Stats& s = t.s;
    s = Stats{};
    t.t0 = Clock::now();
    const OpenCLRuntime::ProgramBuildTimes built_before = rt.take_program_build_times();  // the constructor's
    rt.inject_fault(environment().fault);  // test hook: opencl_runtime.hpp, inject_fault
    // Whatever fails, the runtime is reset (queue drained, events dropped) so that the next frame
    // starts clean, and no partial mesh is returned.
    try {
        t.keep_grid = gradient_normals_wanted(params) || !t.attributes->empty();
        struct Hooks {  // whatever happens, the hooks do not outlive this frame
            Impl& impl;
            ~Hooks() {
                impl.beside_crack_collapse = nullptr;
                impl.crack_kept.clear();
                impl.defer_into = nullptr;
            }
        } hooks{*this};
        const bool unscaled = length_scale_exponent(params.particle_radius) == 0;  // the mesh is the lattice's
        if (defer_triangulation && unscaled) defer_into = &t;
        // The smoothing weights, computed beside the crack collapse where the mesh comes from one
        // unscaled lattice (a host core waits there otherwise); else post-processing computes them.
        if (params.smooth && xyz && unscaled)
            beside_crack_collapse = [&t](const std::vector<float>& positions) {
                t.early_weights = frame_weights(positions, t.grid, t.keep_grid, t.p);
            };
        t.mesh = mesh_in_float_range(xyz, count, params, s);
        rt.end_frame();  // the frame's buffers stay pooled for the next one (trimmed when oversized)
        t.crack_kept = std::move(crack_kept);
        const OpenCLRuntime::ProgramBuildTimes during = rt.take_program_build_times();
        const auto sum = [](double a, double b) { return a < 0 ? b : b < 0 ? a : a + b; };
        t.compiled_ms = sum(built_before.compiled_ms, during.compiled_ms);
        t.loaded_ms = sum(built_before.loaded_ms, during.loaded_ms);
    } catch (const cl::Error& e) {
        const std::string stage = rt.stage().empty() ? std::string("setup") : rt.stage();
        rt.recover();
        throw Error("OpenCL failure in stage " + stage + ": " + e.what() + " returned " + cl_error_name(e.err()) +
                    cl_error_advice(e.err()));
    } catch (const std::bad_alloc&) {
        rt.recover();
        throw Error("out of host memory during reconstruction; use a larger cell, a smaller domain or --memory-limit");
    } catch (...) {
        rt.recover();
        throw;
    }
}

}  // namespace trilevel
