// trilevel: adaptive surface reconstruction of SPH particle sets on 3-level uniform grids
// (Akinci et al., WSCG 2013), parallel on OpenCL, with a sparse coarse grid.
//
// Typical use from a simulator:
//   trilevel::Reconstructor rec;                       // picks and prepares an OpenCL device once
//   trilevel::Params p; p.particle_radius = 0.025f;
//   trilevel::Mesh m = rec.reconstruct(xyz, n, p);      // every frame; buffers and kernels are reused
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

// The OpenCL handle types as <CL/cl.h> declares them (cl_context is `struct _cl_context*`, ...):
// a caller's OpenCL objects can be passed without this header including OpenCL's.
struct _cl_context;
struct _cl_device_id;
struct _cl_command_queue;
struct _cl_mem;
struct _cl_event;

namespace trilevel {

/// Every failure the library reports: a one-line message naming the problem.
class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

enum class Mode {
    Adaptive,  ///< flat coarse cells meshed with cells of 2r, curved/splashing ones with cells of r
    Uniform,   ///< every surface cell meshed with cells of `Params::cell` (the paper's baselines)
};

/// Per-vertex normals of the output mesh (Mesh::normals).
enum class NormalMode {
    None,      ///< no normals (Mesh::normals stays empty)
    Gradient,  ///< grad(phi)/|grad(phi)| of the scalar field (docs/design.md §3.3) at the vertex: the normal
               ///< of the smooth surface the mesh approximates
    Area,      ///< sum of the adjacent triangles' normals weighted by their area: the mesh's own shading normal
};

/// How the cracks between level-2 and level-3 cells are closed (docs/design.md §7).
enum class CrackClosing {
    Collapse,  ///< patches, then each inner crossing of a transition face merged into the level-2
               ///< crossing beside it where that keeps the mesh closed and unfolded: two triangles
               ///< fewer per merged vertex, most patches gone
    Patches,   ///< the patches alone: every crack polygon triangulated by ear clipping (paper §3.3.2)
};

/// An axis-aligned box in world units: the points p with min[k] <= p[k] <= max[k] on every axis.
/// Valid when every bound is finite and min[k] < max[k].
struct Box {
    float min[3] = {0.0f, 0.0f, 0.0f};
    float max[3] = {0.0f, 0.0f, 0.0f};
};

/// Reconstruction parameters. Lengths are in multiples of the particle radius r unless stated;
/// positions (input and output) are in world units.
struct Params {
    float particle_radius = 0.0f;      ///< r, in world units (half the rest spacing); required, > 0
    float kernel_radius = 4.0f;        ///< R, support of the SPH kernels, in r (docs/design.md §2)
    Mode mode = Mode::Adaptive;        ///< see Mode
    float cell = 1.0f;                 ///< uniform mode: marching-cubes cell size in r (is_uniform_cell)
    float curvature_threshold = 0.0f;  ///< adaptive mode: mean cell curvature (paper eq. 3) at which a
                                       ///< coarse cell becomes level 3; 0 picks the calibrated default.
                                       ///< Dimensionless: sum over neighbours of (1 - n_i.n_j)(1 - d/R)
    float level2_tolerance = 0.32f;    ///< adaptive mode, the level-2 check (host/level2_check.hpp): a level-2
                                       ///< cell whose curvature is not clearly flat (>= 3) becomes level 3 where
                                       ///< the field at the centre of one of its crossed cubes of 2r differs from
                                       ///< the trilinear value by more than this many r; 0 = off (then curvature
                                       ///< alone decides: docs/calibration.md, "Levels and choosing the threshold")
    std::uint64_t memory_limit_bytes = 0;  ///< bytes; budget for the largest allocations; 0: device and host limits
    float level_hysteresis = 0.0f;     ///< adaptive mode, frame sequences: a coarse cell keeps its level of the
                                       ///< previous frame until its curvature passes the threshold by this
                                       ///< fraction of the threshold (level 3 stays 3 down to threshold (1 - h),
                                       ///< level 2 stays 2 up to threshold (1 + h)); the level-2 check's
                                       ///< tolerance is held likewise (times 1 - h for a cell that was level 3,
                                       ///< 1 + h for one that was level 2). In [0, 1), 0 = off (each call
                                       ///< independent of the previous). The CLI uses 0.2 for sequences
                                       ///< (docs/calibration.md, "Temporal coherence").
    NormalMode normals = NormalMode::None; ///< per-vertex normals to compute (Mesh::normals)
    CrackClosing crack_closing = CrackClosing::Collapse;  ///< adaptive mode: see CrackClosing
    /// Particles outside this box (world units, bounds inclusive) are ignored, with their
    /// attributes, before anything else: the mesh is the one of the particles inside, bit for bit
    /// (like splashsurf's particle AABB). Unset: every particle. Throws Error when none is inside.
    std::optional<Box> particle_box;
    /// Connected components (by vertex index) of the mesh that enclose less than this many particle
    /// volumes, N (2r)^3, are removed: stray blobs of a few stuck or lost particles. The enclosed
    /// volume is |V| by the divergence theorem, so a closed inner surface (a cavity, negative V)
    /// below the size is removed too, i.e. the small bubble is filled. >= 0, finite; 0 = off.
    /// Runs after the mesh is made, before clip_box. Counted in Stats::components_removed.
    float remove_components_below = 0.0f;
    /// The surface is cut at this box (world units) and closed there with flat caps on its faces,
    /// so the mesh stays closed and oriented by index and every vertex lies in the box (vertices
    /// within about 1e-3 r of a face are first moved inside along its normal, by at most 2e-3 r:
    /// docs/postprocessing.md). Applied
    /// last. Cap triangles are TriangleKind::Patch (Stats::clip_cap_triangles); a vertex made on a
    /// cut edge takes the lower level of the edge's two ends. A box that holds no fluid gives an
    /// empty mesh (no triangles), which counts as closed. Unset: no clipping.
    std::optional<Box> clip_box;
    /// Smoothing for rendering (docs/smoothing.md): weighted Laplacian smoothing after Löschner et
    /// al. (VMV 2023), each vertex weighted by how many particles it sees (the vertices of splash
    /// and thin sheets barely move), the curvature shrink given back and a per-component volume correction
    /// along the normals. Moves vertices only: the mesh stays closed and oriented by index, each
    /// component keeps its volume. Turns sliver_cleanup on. With normals, NormalMode::Gradient gives
    /// the area-weighted normals of the smoothed mesh (the field's gradient no longer matches
    /// moved vertices). Off by default: the mesh is then exactly the unsmoothed one.
    bool smooth = false;
    /// Laplacian smoothing steps when `smooth` is on (more: smoother and slower); 0 picks kDefaultSmoothIterations.
    int smooth_iterations = 0;
    /// Collapses the needle triangles marching cubes makes where the surface passes near a lattice
    /// point (an edge under 0.15 of its triangle's longest), by index, keeping the mesh a closed
    /// oriented 2-manifold (link condition, no triangle turned over); on with `smooth`.
    bool sliver_cleanup = false;
};

/// Smoothing iterations that Params::smooth uses by default (chosen on the analytic test bodies,
/// bench/RESULTS-smoothing.md), and the most Params::smooth_iterations takes.
constexpr int kDefaultSmoothIterations = 12;
constexpr int kMaxSmoothIterations = 1000;

/// The range of Params::kernel_radius, in particle radii.
constexpr int kMinKernelRadius = 1, kMaxKernelRadius = 16;

/// A named quantity per particle (input) or per mesh vertex (output): velocity, density, ...
struct Attribute {
    std::string name;           ///< as named in the file; no white space (PLY and VTK headers)
    int components = 1;         ///< 1 (scalar) or 3 (vector)
    std::vector<float> values;  ///< `components` floats per element, in element order
};
using ParticleAttribute = Attribute;  ///< values per particle, in particle order
using VertexAttribute = Attribute;    ///< values per mesh vertex, in vertex order

/// Whether `cell` is a Params::cell that uniform mode takes: 4/cell an even whole number from 2 to
/// 64, i.e. 2, 1, 2/3, 0.5, 0.4, ... 1/16 r. The coarse cell of 4 r is cut into that many lattice
/// steps, and the mesher closes cracks on the lattice of every other point, so the count is even.
bool is_uniform_cell(float cell);
/// The rule is_uniform_cell checks, in words, for messages.
extern const char* const kUniformCellRule;

/// Throws Error, one line naming the parameter, for parameters that every frame would refuse
/// (Reconstructor::reconstruct checks them first; FramePipeline at construction).
void check_params(const Params& params);

/// Calibrated default of Params::curvature_threshold (dimensionless; docs/calibration.md, "Levels and choosing the threshold").
float default_curvature_threshold();

/// Kind of a triangle in an adaptive mesh (paper Table 1: level-2, level-3 and patch triangles).
enum class TriangleKind : std::uint8_t { Level2 = 0, Level3 = 1, Patch = 2 };

/// An indexed triangle mesh, closed and consistently oriented (counter-clockwise seen from outside).
struct Mesh {
    std::vector<float> positions;            ///< x, y, z per vertex (world units)
    std::vector<std::uint32_t> triangles;    ///< three vertex indices per triangle
    std::vector<std::uint8_t> vertex_level;  ///< 2 or 3: finest lattice level the vertex lies on
    std::vector<TriangleKind> triangle_kind; ///< one per triangle
    std::vector<float> normals;              ///< x, y, z per vertex, unit length, outward; empty unless
                                             ///< Params::normals asks for them (NormalMode::Area: zero
                                             ///< at a vertex whose triangles all have zero area)
    std::vector<VertexAttribute> attributes; ///< particle attributes interpolated at the vertices

    std::size_t vertex_count() const { return positions.size() / 3; }
    std::size_t triangle_count() const { return triangles.size() / 3; }
};

/// What one reconstruction did and cost (docs/design.md §10). Counts unless stated; cells are coarse cells
/// of 4r, the "level" of a cell is the lattice it is meshed on (2: step 2r, 3: step r).
struct Stats {
    std::size_t particles = 0;              ///< input particles
    std::size_t surface_particles = 0;      ///< particles near the surface (colour-field gradient, docs/design.md §3.1)
    std::size_t splash_particles = 0;       ///< particles with fewer than 3 neighbours within R
    std::size_t surface_cells = 0;          ///< coarse cells after band closure
    std::size_t surface_cells_level2 = 0;   ///< of those, cells meshed on the 2r lattice
    std::size_t surface_cells_level3 = 0;   ///< of those, cells meshed on the r lattice
    std::size_t splash_cells = 0;           ///< cells forced to level 3 by a nearby splash or thin particle
    std::size_t isolated_piece_cells = 0;   ///< level-2 cells made level 3 as part of an isolated piece (a small droplet)
    std::size_t band_closure_cells = 0;     ///< coarse cells added by band closure (docs/design.md §7)
    std::size_t level2_check_cells = 0;     ///< level-2 cells the level-2 check made level 3 (docs/design.md §3.2)
    std::size_t fine_points = 0;            ///< unique fine lattice points evaluated
    std::size_t fine_points_level2 = 0;     ///< of those, points on the level-2 lattice
    std::size_t fine_points_level3 = 0;     ///< of those, points only on the level-3 lattice
    std::size_t vertices = 0;               ///< of the mesh (Mesh::vertex_count)
    std::size_t triangles = 0;              ///< of the mesh; the sum of the three kinds below
    std::size_t triangles_level2 = 0;       ///< TriangleKind::Level2
    std::size_t triangles_level3 = 0;       ///< TriangleKind::Level3
    std::size_t triangles_patch = 0;        ///< TriangleKind::Patch (crack closing, docs/design.md §7)
    std::size_t crack_vertices_collapsed = 0; ///< inner crack crossings merged away (CrackClosing::Collapse)
    std::size_t sliver_edges_collapsed = 0;   ///< needle edges collapsed (Params::sliver_cleanup)
    std::size_t smoothing_reverted_moves = 0; ///< smoothing moves taken back where a triangle would turn over
    std::size_t particles_outside_box = 0;  ///< particles Params::particle_box ignored (of `particles`)
    std::size_t components_removed = 0;     ///< components Params::remove_components_below dropped
    std::size_t clip_cap_triangles = 0;     ///< triangles of the caps Params::clip_box made (on the box faces)
    /// Milliseconds (wall) per stage in pipeline order, then "total". First, when the Reconstructor
    /// built OpenCL programs since the previous call's statistics: "kernel_compile" (compiled from
    /// source: the first run on a device, seconds) and/or "kernel_load" (loaded from the on-disk
    /// program cache, milliseconds). Mostly spent in the constructor, so not part of "total"; a
    /// program built on demand during the call (64-bit fine keys) is in its stage's time too.
    std::vector<std::pair<std::string, double>> time_ms;
    std::vector<std::pair<std::string, double>> kernel_ms; ///< milliseconds of OpenCL profiling time per kernel
    std::uint64_t peak_memory_bytes = 0;   ///< bytes; process peak resident memory after the run
    /// Bytes of device buffers the run held at once at its peak (the largest of a split domain's
    /// parts): the smallest Params::memory_limit_bytes its device buffers fit (the limit bounds
    /// large host arrays too). The Reconstructor keeps its buffers for the next frame in a pool
    /// that may hold more (growth slack, roles this frame did not use).
    std::uint64_t device_memory_bytes = 0;
    bool closed = false;                   ///< every edge used twice in opposite directions
    /// Temporal coherence (adaptive mode, every frame after the first of a sequence): coarse cells
    /// this frame shares with the previous one, how many of those changed level, and how many
    /// cells Params::level_hysteresis held at their previous level.
    bool level_history = false;            ///< a previous frame was compared (the three below are set)
    std::size_t level_cells_compared = 0;
    std::size_t level_flips = 0;
    std::size_t level_held = 0;
    std::string device;                    ///< the OpenCL device that ran the kernels
    unsigned device_compute_units = 0;     ///< its compute units (PoCL: threads, POCL_MAX_PTHREAD_COUNT)
    unsigned host_threads = 0;             ///< threads the host stages could use (the caller's TBB arena)
};

/// Writes the statistics as a JSON object (keys as in docs/operations.md "Statistics"), with `params` under
/// "parameters" (the curvature threshold actually used).
std::string stats_to_json(const Stats& stats, const Params& params);

/// An OpenCL device as listed by `trilevel devices`.
struct DeviceInfo {
    int index = 0;            ///< global index over all platforms, as accepted by --device
    std::string platform;     ///< OpenCL platform name, e.g. "Portable Computing Language"
    std::string name;         ///< device name, as in Stats::device
    std::string type;         ///< "GPU", "CPU", "ACCELERATOR", "OTHER"
    unsigned compute_units = 0;       ///< CL_DEVICE_MAX_COMPUTE_UNITS
    std::uint64_t global_memory = 0;  ///< bytes (CL_DEVICE_GLOBAL_MEM_SIZE)
    std::uint64_t max_allocation = 0; ///< bytes, largest single buffer (CL_DEVICE_MAX_MEM_ALLOC_SIZE)
    bool int64_atomics = false; ///< cl_khr_int64_base_atomics, required
};

/// Lists every OpenCL device of every platform. Throws Error when no platform exists.
std::vector<DeviceInfo> list_devices();

/// Particle positions in an OpenCL buffer of the caller's (a GPU simulator's), for
/// Reconstructor::reconstruct(const DevicePositions&, ...). Particle i's x, y, z are the three
/// floats at byte offset + i * stride of `buffer`.
struct DevicePositions {
    _cl_mem* buffer = nullptr;  ///< a cl_mem of the Reconstructor's context, readable by kernels;
                                ///< only read, and only during the call
    std::size_t count = 0;      ///< particles
    std::size_t offset = 0;     ///< bytes before particle 0's x; a multiple of 4
    std::size_t stride = 12;    ///< bytes from one particle to the next, a multiple of 4 and >= 12:
                                ///< 12 for packed float3 (x, y, z), 16 for float4 (x, y, z, w; w unread)
    /// Events to complete before the buffer is read (a simulator's kernel on another queue of the
    /// context); empty when the queue's order suffices. Not retained beyond the call.
    std::vector<_cl_event*> wait_for;
};

/// Said before a Reconstructor compiles its OpenCL kernels from source because the on-disk program
/// cache holds none for this device, driver and library version (the first run on a machine, or
/// caching off). Compiling takes seconds (about 5 s on PoCL); a cached program loads in milliseconds.
/// The cache is $TRILEVEL_CACHE_DIR if set (empty: off), else $XDG_CACHE_HOME/trilevel, else
/// $HOME/.cache/trilevel.
struct KernelCompileNotice {
    std::string device;     ///< the device's name (DeviceInfo::name)
    std::string cache_dir;  ///< where the compiled program is kept for the next start; empty: caching is off
};

/// Reconstructs surfaces on one OpenCL device; keeps compiled kernels and buffers across calls.
/// Not thread-safe: use one Reconstructor per thread.
class Reconstructor {
public:
    /// device < 0: the TRILEVEL_DEVICE environment variable, else the first GPU, else the first CPU.
    /// on_compile, when set, is called on the calling thread just before a program is compiled
    /// from source instead of loaded from the cache: in the constructor, or in a reconstruct() that
    /// first needs the kernels of 64-bit fine keys (the CLI prints the first one on stderr).
    explicit Reconstructor(int device = -1, std::function<void(const KernelCompileNotice&)> on_compile = {});
    /// Runs on a caller's OpenCL objects (a GPU simulator's), so that reconstruct(DevicePositions)
    /// reads the caller's buffers where they are. `context` must hold `device`, which needs
    /// cl_khr_int64_base_atomics. `queue`: an in-order command queue of that context and device
    /// (an out-of-order one is an Error) to which every command of the Reconstructor goes, after
    /// whatever the caller enqueued on it before each call; null: the Reconstructor makes its own
    /// queue on the context. Stats::kernel_ms needs CL_QUEUE_PROFILING_ENABLE on the queue
    /// (without it, it stays empty).
    /// Lifetimes: the Reconstructor retains the context, device and queue (clRetain*) and releases
    /// them when destroyed, so the caller may release its own references whenever it likes. Its
    /// device buffers are allocated in that context (Params::memory_limit_bytes counts only
    /// those) and released by the Reconstructor. The kernels are built for the device on
    /// construction, as with the other constructor (program cache: README).
    Reconstructor(_cl_context* context, _cl_device_id* device, _cl_command_queue* queue = nullptr);
    ~Reconstructor();
    Reconstructor(Reconstructor&&) noexcept;
    Reconstructor& operator=(Reconstructor&&) noexcept;

    /// `xyz` holds `count` particles as x, y, z floats in world units (finite; read only during the
    /// call). `params` as documented there; `stats`, when not null, receives what the run did and
    /// cost. Returns the closed mesh. Throws Error on bad input or resources.
    /// Successive calls are taken as successive frames of one sequence: in adaptive mode the levels
    /// of each frame are remembered for the next (used when Params::level_hysteresis > 0; reported
    /// in Stats::level_flips).
    Mesh reconstruct(const float* xyz, std::size_t count, const Params& params, Stats* stats = nullptr);

    /// Forgets the previous frame's levels: call before the first frame of a new sequence (or
    /// between unrelated inputs) so that it is reconstructed as if alone. A change of radius,
    /// kernel radius, mode or cell resets the history too.
    void reset_history();
    /// The same, and every attribute interpolated at the mesh vertices (Mesh::attributes, same
    /// order) with Shepard-normalised SPH weights: A(v) = sum_j k_j A_j / sum_j k_j, with the
    /// field's kernel k_j = (1 - |v - x_j|^2 / R^2)^3 over the particles within R; exact for
    /// constant attributes. A vertex with no particle within R takes its nearest particle's value.
    /// Each attribute needs `components` (1 or 3) finite values per particle and a distinct name.
    Mesh reconstruct(const float* xyz, std::size_t count, const Params& params, Stats* stats,
                     const std::vector<ParticleAttribute>& attributes);
    /// The same, taking the positions (x, y, z per particle) over: once they are on the device they
    /// are freed unless normals, attributes or smoothing need them later, which lowers the peak memory by 12
    /// bytes a particle (the CLI uses it).
    Mesh reconstruct(std::vector<float>&& xyz, const Params& params, Stats* stats = nullptr,
                     const std::vector<ParticleAttribute>& attributes = {});

    /// The same, on positions in an OpenCL buffer (DevicePositions) of this Reconstructor's
    /// context, meshed without a host round trip: a bounds pass and a gather into the binning input
    /// run on the device. The mesh is bit-identical to the host-array path's on the same floats.
    /// Synchronisation: the buffer is read by commands on the Reconstructor's queue, after the
    /// events of `positions.wait_for` and after what the queue held before the call (in order).
    /// The call returns when all it enqueued has completed (it waits for the queue, so also for
    /// what the caller enqueued there before), so the buffer may be written or released then.
    /// A frame like the others for the level history. The positions are read back to the host
    /// (count x 12 bytes, then the host path) only where the device path cannot give the same
    /// bits: a device without cl_khr_fp64 (the lattice origin is subtracted in double precision),
    /// Params::normals == NormalMode::Gradient or Params::smooth (the normals and the smoothing
    /// weights read the particles on the host), a
    /// radius outside [2^-10, 2^10] (scaled on the host) or particles too far apart for one lattice
    /// (split on the host). Errors as for the host path (a non-finite coordinate names the
    /// particle), plus a layout that does not fit the buffer or a buffer of another context.
    Mesh reconstruct(const DevicePositions& positions, const Params& params, Stats* stats = nullptr);

    /// The OpenCL device this Reconstructor runs on.
    const DeviceInfo& device() const;

private:
    friend class FramePipeline;
    /// FramePipeline's split of reconstruct(std::vector<float>&&, ...): the device stages run now;
    /// the host-only rest (post-processing, normals, attributes, and with `defer_triangulation`
    /// the triangulation and crack closing too, where the frame is meshed on one lattice) is
    /// returned, to be called once, on any thread, also while this Reconstructor meshes the next
    /// frame. `stats` must stay where it is until then.
    std::function<Mesh()> mesh_then_finish(std::vector<float>&& xyz, const Params& params, Stats& stats,
                                           std::vector<ParticleAttribute> attributes, bool defer_triangulation);
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// Checks a mesh by index topology: every directed edge appears once and its reverse once.
bool is_closed_and_oriented(const Mesh& mesh);

}  // namespace trilevel
