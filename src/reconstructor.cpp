// Pipeline orchestration (DESIGN §2): device stages 1-6, then band closure, transition continuity,
// triangulation and crack closing on the host. Each stage is timed on its own.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <cmath>
#include <limits>
#include <optional>
#include <unordered_map>

#include <sys/resource.h>

#include "band_closure.hpp"
#include "device_stages.hpp"
#include "edge_refinement.hpp"
#include "level_history.hpp"
#include "opencl_runtime.hpp"
#include "stage_constants.hpp"
#include "surface_mesher.hpp"
#include "transition_continuity.hpp"
#include "vertex_data.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {

float default_curvature_threshold() { return constants::kDefaultCurvatureThreshold; }

namespace {

using Clock = std::chrono::steady_clock;

/// Appends the wall time of each stage to Stats::time_ms.
class StageTimer {
public:
    explicit StageTimer(Stats& s) : stats_(s), start_(Clock::now()), last_(start_) {}
    void stage(const char* name) {
        auto now = Clock::now();
        stats_.time_ms.emplace_back(name, std::chrono::duration<double, std::milli>(now - last_).count());
        last_ = now;
    }
    void restart() { last_ = Clock::now(); }

private:
    Stats& stats_;
    Clock::time_point start_, last_;
};

void require_positive(float v, const char* name, const char* why) {
    if (!std::isfinite(v) || v <= 0.0f)
        throw Error(std::string(name) + " must be finite and > 0 (" + why + "), got " + std::to_string(v));
}

void validate(const Params& p) {
    require_positive(p.particle_radius, "particle radius", "half the particle spacing, world units");
    require_positive(p.kernel_radius, "kernel radius", "in particle radii");
    if (p.kernel_radius < 1.0f || p.kernel_radius > 16.0f)
        throw Error("kernel radius must lie in [1, 16] particle radii, got " + std::to_string(p.kernel_radius));
    if (p.mode == Mode::Uniform) {
        require_positive(p.cell, "cell size", "in particle radii");
        float steps = constants::kCoarseCell / p.cell;
        if (std::fabs(steps - std::round(steps)) > 1e-4f || std::round(steps) < 1.0f || std::round(steps) > 64.0f)
            throw Error("cell size " + std::to_string(p.cell) + " must divide the coarse cell of 4 radii (e.g. 0.5, 1, 2, 4)");
    }
    if (p.normals != NormalMode::None && p.normals != NormalMode::Gradient && p.normals != NormalMode::Area)
        throw Error("normals must be NormalMode::None, Gradient or Area");
    if (p.mode == Mode::Adaptive && p.curvature_threshold != 0.0f && !(std::isfinite(p.curvature_threshold) && p.curvature_threshold > 0.0f))
        throw Error("curvature threshold must be finite and > 0, got " + std::to_string(p.curvature_threshold));
    if (!(p.level_hysteresis >= 0.0f && p.level_hysteresis < 1.0f))
        throw Error("level hysteresis must lie in [0, 1) (a fraction of the curvature threshold), got " +
                    std::to_string(p.level_hysteresis));
}

/// Lattice and coarse grid of a frame. Adaptive and uniform --cell 2 use lattice step r with
/// coarse cells of 4 steps (levels 3 and 2); other uniform cells use step = cell.
struct Grid {
    LatticeFrame frame;
    glm::dvec3 origin;  ///< double-precision lattice origin; particles are uploaded relative to it
    CoarseBase coarse_base{};  ///< origin / coarse_edge: a whole number, so frames share one lattice
    float coarse_edge = 0.0f;
    int forced_level = 0;  ///< 0: adaptive
};

Grid make_grid(const Params& p, const float* xyz, std::size_t n) {
    Grid g;
    const double r = p.particle_radius;
    g.coarse_edge = float(constants::kCoarseCell * r);
    if (p.mode == Mode::Uniform) {
        int steps = int(std::lround(constants::kCoarseCell / p.cell));
        g.forced_level = (steps == 2) ? 2 : 3;
        g.frame.coarse_steps = (steps == 2) ? 4 : steps;
    } else {
        g.frame.coarse_steps = 4;
    }
    g.frame.step = float(constants::kCoarseCell * r / g.frame.coarse_steps);
    glm::dvec3 lo(std::numeric_limits<double>::max()), hi(std::numeric_limits<double>::lowest());
    for (std::size_t i = 0; i < n; ++i) {
        glm::dvec3 x(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
        if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
            throw Error("particle " + std::to_string(i) + " has a non-finite coordinate");
        lo = glm::min(lo, x);
        hi = glm::max(hi, x);
    }
    const double edge = g.coarse_edge;
    // Two coarse cells of margin: the surface lies within R = one coarse cell of the particles.
    // Snapped to whole coarse cells, so every frame of a sequence uses the same global lattice
    // (level_history.hpp).
    const glm::dvec3 base = glm::floor(lo / edge) - 2.0;
    g.origin = base * edge;
    for (int a = 0; a < 3; ++a) g.coarse_base[std::size_t(a)] = std::int64_t(base[a]);
    g.frame.origin = glm::vec3(g.origin);
    glm::dvec3 extent = (hi - g.origin) / double(g.frame.step) + 3.0 * g.frame.coarse_steps;
    double worst = std::max({extent.x, extent.y, extent.z});
    if (worst > lattice::kMaxCoord)
        throw Error("the particles span " + std::to_string(long(worst)) + " lattice steps on one axis, more than the " +
                    std::to_string(lattice::kMaxCoord) + " the 20-bit lattice keys hold; use a larger cell or split the domain");
    return g;
}

std::vector<glm::vec4> relative_positions(const float* xyz, std::size_t n, glm::dvec3 origin) {
    std::vector<glm::vec4> out(n);
    for (std::size_t i = 0; i < n; ++i)
        out[i] = glm::vec4(glm::vec3(glm::dvec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]) - origin), 0.0f);
    return out;
}

std::vector<CoarseCell> merge_cells(const std::vector<CoarseCell>& a, const std::vector<CoarseCell>& b) {
    std::vector<CoarseCell> out;
    out.reserve(a.size() + b.size());
    std::merge(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out),
               [](const CoarseCell& x, const CoarseCell& y) { return lattice::pack(x.coord) < lattice::pack(y.coord); });
    return out;
}

void count_points(const FinePointMap& map, Stats& s) {
    for (std::uint64_t k : map.keys()) {
        if (k == lattice::kEmptyKey) continue;
        glm::ivec3 p = lattice::unpack(k);
        bool even = ((p.x | p.y | p.z) & 1) == 0;
        (even ? s.fine_points_level2 : s.fine_points_level3)++;
    }
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

/// Stages 5-8 until the band is closed (DESIGN §7): refine and evaluate the new cells, apply
/// transition continuity, find the faces the surface leaves through, add those neighbours and
/// repeat. Returns a view of the mapped fine-point table; `cells` gains the added cells.
FinePointMap close_band(OpenCLRuntime& rt, FinePoints& points, std::vector<CoarseCell>& cells,
                        const LatticeFrame& frame, const BinnedParticles& bins, float r, float R, Stats& s) {
    std::vector<CoarseCell> fresh = cells;
    double t_field = 0, t_closure = 0;
    for (;;) {
        auto t0 = Clock::now();
        refine_and_evaluate(rt, points, fresh, frame, bins, r, R);
        FinePointMap field = map_fine_points(rt, points);
        auto t1 = Clock::now();
        apply_transition_continuity(cells, frame, field);
        fresh = band_closure_cells(cells, frame, field);
        auto t2 = Clock::now();
        t_field += std::chrono::duration<double, std::milli>(t1 - t0).count();
        t_closure += std::chrono::duration<double, std::milli>(t2 - t1).count();
        if (fresh.empty()) {
            s.time_ms.emplace_back("scalar_field", t_field);
            s.time_ms.emplace_back("band_closure", t_closure);
            return field;
        }
        field = FinePointMap();
        unmap_fine_points(rt, points);
        s.band_closure_cells += fresh.size();
        cells = merge_cells(cells, fresh);
    }
}

/// Stage 8b (host/edge_refinement.hpp): true values at the midpoints of crossed level-2 edges.
/// Continuity never touches these points (no level-3 cell holds them), and the values it wrote
/// stay in the table (a rehash copies them). `field` is re-mapped.
void refine_level2_edges(OpenCLRuntime& rt, FinePoints& points, FinePointMap& field,
                         const std::vector<CoarseCell>& cells, const LatticeFrame& frame, const BinnedParticles& bins,
                         float r, float R) {
    Level2Midpoints mids = level2_crossing_midpoints(cells, frame, field);
    if (mids.keys.empty()) return;
    field = FinePointMap();
    unmap_fine_points(rt, points);
    insert_and_evaluate(rt, points, mids.keys, mids.holders, frame, bins, r, R);
    field = map_fine_points(rt, points);
}

/// Stage 11 (host/vertex_data.hpp): normals and attributes at the vertices, each timed when asked for.
void add_vertex_data(Mesh& mesh, const float* xyz, std::size_t n, const Params& p,
                     const std::vector<ParticleAttribute>& attributes, StageTimer& timer) {
    if (p.normals == NormalMode::None && attributes.empty()) return;
    const float r = p.particle_radius, R = p.kernel_radius * r;
    std::optional<reference::ParticleGrid> grid;  // only the area-weighted normals need no particles
    if (p.normals == NormalMode::Gradient || !attributes.empty()) grid.emplace(vertex_particle_grid(xyz, n, r, R));
    if (p.normals != NormalMode::None) {
        mesh.normals = area_weighted_normals(mesh);
        if (p.normals == NormalMode::Gradient) mesh.normals = gradient_normals(mesh, *grid, r, R, mesh.normals);
        timer.stage("normals");
    }
    if (!attributes.empty()) {
        mesh.attributes = interpolate_attributes(mesh, *grid, xyz, n, R, attributes);
        timer.stage("attributes");
    }
}

std::uint64_t peak_rss_bytes() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return std::uint64_t(u.ru_maxrss) * 1024;
}

/// Whether two parameter sets give the same lattice and the same curvature, so that the levels
/// of one frame are comparable with those of the next.
bool same_levels_frame(const Params& a, const Params& b) {
    return a.particle_radius == b.particle_radius && a.kernel_radius == b.kernel_radius && a.mode == b.mode &&
           a.cell == b.cell;
}

}  // namespace

struct Reconstructor::Impl {
    explicit Impl(int device) : rt(device) {}
    OpenCLRuntime rt;
    LevelHistory history;  ///< levels of the previous frame (adaptive mode)
    Params history_params;
    Mesh run(const float* xyz, std::size_t n, const Params& p, const std::vector<ParticleAttribute>& attributes,
             Stats& s);
    void remember_levels(const std::vector<CoarseCell>& cells, const Grid& g, const Params& p, Stats& s);
};

Mesh Reconstructor::Impl::run(const float* xyz, std::size_t n, const Params& p,
                              const std::vector<ParticleAttribute>& attributes, Stats& s) {
    StageTimer timer(s);
    const Grid g = make_grid(p, xyz, n);
    const float r = p.particle_radius, R = p.kernel_radius * r;
    const float threshold = p.curvature_threshold > 0.0f ? p.curvature_threshold : default_curvature_threshold();
    s.particles = n;
    s.device = rt.info().name;
    rt.reset_budget(p.memory_limit_bytes);

    BinnedParticles bins = bin_particles(rt, relative_positions(xyz, n, g.origin), R);
    timer.stage("binning");
    ParticleClasses classes = classify_particles(rt, bins, r, R);
    s.surface_particles = classes.surface;
    s.splash_particles = classes.splash;
    timer.stage("surface_particles");
    SurfaceCells sc = surface_cells(rt, bins, classes, r, R, g.coarse_edge, threshold, g.forced_level);
    for (std::uint8_t f : sc.splash) s.splash_cells += f;
    if (!history.empty() && !same_levels_frame(history_params, p)) history.reset();
    if (g.forced_level == 0)
        s.level_held = history.apply(sc.cells, sc.curvature, sc.splash, g.coarse_base, threshold, p.level_hysteresis);
    classes = ParticleClasses{};  // memory follows the surface from here on (DESIGN §4)
    sc.particle_kappa = {};
    timer.stage("surface_cells");

    std::vector<CoarseCell> cells = sc.cells;
    FinePoints points;
    FinePointMap field = close_band(rt, points, cells, g.frame, bins, r, R, s);
    timer.restart();  // close_band recorded its own two entries
    refine_level2_edges(rt, points, field, cells, g.frame, bins, r, R);
    bins = BinnedParticles{};
    timer.stage("edge_refinement");
    s.surface_cells = cells.size();
    for (const auto& c : cells) (c.level == 2 ? s.surface_cells_level2 : s.surface_cells_level3)++;
    count_points(field, s);

    Mesh mesh = triangulate_cells(cells, g.frame, field);
    field = FinePointMap();
    unmap_fine_points(rt, points);
    points = FinePoints{};
    timer.stage("triangulation");
    add_vertex_data(mesh, xyz, n, p, attributes, timer);
    count_mesh(mesh, s);
    s.closed = is_closed_and_oriented(mesh);
    remember_levels(cells, g, p, s);
    for (auto& [name, ms] : rt.take_kernel_times()) s.kernel_ms.emplace_back(name, ms);
    s.peak_memory_bytes = peak_rss_bytes();
    s.device_memory_bytes = rt.allocated_bytes();
    return mesh;
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
}

Reconstructor::Reconstructor(int device) : impl_(std::make_unique<Impl>(device)) {}
Reconstructor::~Reconstructor() = default;
Reconstructor::Reconstructor(Reconstructor&&) noexcept = default;
Reconstructor& Reconstructor::operator=(Reconstructor&&) noexcept = default;
const DeviceInfo& Reconstructor::device() const { return impl_->rt.info(); }
void Reconstructor::reset_history() { impl_->history.reset(); }

Mesh Reconstructor::reconstruct(const float* xyz, std::size_t count, const Params& params, Stats* stats) {
    return reconstruct(xyz, count, params, stats, {});
}

Mesh Reconstructor::reconstruct(const float* xyz, std::size_t count, const Params& params, Stats* stats,
                                const std::vector<ParticleAttribute>& attributes) {
    validate(params);
    if (count == 0) throw Error("no particles to reconstruct (the input is empty)");
    if (count > std::numeric_limits<std::uint32_t>::max() / 2) throw Error("too many particles for one frame");
    validate_attributes(attributes, count);
    Stats local;
    Stats& s = stats ? *stats : local;
    s = Stats{};
    auto t0 = Clock::now();
    try {
        Mesh m = impl_->run(xyz, count, params, attributes, s);
        s.time_ms.emplace_back("total", std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        return m;
    } catch (const cl::Error& e) {
        throw Error(std::string("OpenCL call ") + e.what() + " failed: " + cl_error_name(e.err()));
    } catch (const std::bad_alloc&) {
        throw Error("out of host memory during reconstruction; use a larger cell or --memory-limit");
    }
}

}  // namespace trilevel
