// The OpenCL stages of the pipeline (docs/design.md §2: stages 1-6 and 8b), each a function from buffers to
// buffers. Particle positions are relative to the lattice origin. Buffers come from the runtime's
// pool (buffer_pool.hpp) and go back to it when these structs are destroyed. The tests compare each stage
// with its plain C++ reference in tests/reference/.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <glm/glm.hpp>

#include "core/coarse_cells.hpp"
#include "core/fine_point_map.hpp"
#include "kernel_contract.hpp"
#include "mapped_buffer.hpp"
#include "opencl_runtime.hpp"

namespace trilevel {

/// A lock-free hash on the device: its keys and its counters (values, where a table has them,
/// are a parallel array its owner keeps, e.g. FinePoints::values).
struct DeviceHash {
    DeviceBuffer keys;
    DeviceBuffer stats;  ///< int[2]: overflow flag, keys inserted
    std::size_t capacity = 0;
};

/// Stage 1: particles binned by a stable counting sort into a sparse grid of cell `cell`.
struct BinnedParticles {
    std::size_t count = 0;
    float cell = 0.0f;      ///< bin edge (the kernel radius R)
    DeviceBuffer sorted;      ///< positions in bin order, packed xyz (3 floats a particle)
    DeviceBuffer order;       ///< uint: sorted index -> input index; the binning's own intermediate (the
                              ///< gather reads it), kept for the tests to map results back to input
                              ///< order (the pipeline drops it after binning)
    DeviceHash bins;        ///< occupied bins
    DeviceBuffer range;       ///< uint2 per bin slot: first sorted index, count
    DeviceBuffer occupied;    ///< uint: the slots of the non-empty bins
    std::size_t occupied_count = 0;
    std::uint64_t pair_load = 0;  ///< sum over bins of count^2: the neighbour work, before it is done
};
/// Called with BinnedParticles::pair_load once the bins are counted, before the particles are
/// sorted into them; it throws to stop a binning whose work would not end. Each bin's particles are
/// put in index order one bin a work-item, quadratic in the bin's count: a pile of millions of
/// particles on one spot would sort for hours before its neighbour sums were refused.
using PairLoadCheck = std::function<void(std::uint64_t pair_load)>;

/// Stage 1 on `n` particles (x, y, z floats), uploaded relative to `origin` (subtracted in double
/// precision) straight into the device buffer: no host copy of them. `uploaded`, when given, is
/// called once `xyz` is no longer read (the caller may free it there).
BinnedParticles bin_particles(OpenCLRuntime& rt, const float* xyz, std::size_t n, glm::dvec3 origin, float cell,
                              const std::function<void()>& uploaded = {}, const PairLoadCheck& check_load = {});
/// Stage 1 on positions already on the device: `pos` (role "particle positions") holds `n`
/// packed x, y, z relative to the lattice origin (device_input.hpp fills it from a caller's buffer).
BinnedParticles bin_positions(OpenCLRuntime& rt, DeviceBuffer pos, std::size_t n, float cell,
                              const PairLoadCheck& check_load = {});

/// Stage 2: colour-field gradient per sorted particle; flags bit 0 surface, bit 1 splash, bit 2 thin.
struct ParticleClasses {
    DeviceBuffer gradient;  ///< packed xyz, 3 floats a particle; the curvature pass turns it into normals
    DeviceBuffer flags;     ///< uchar
    std::size_t surface = 0, splash = 0;
};
ParticleClasses classify_particles(OpenCLRuntime& rt, const BinnedParticles& bins, float r, float R);

/// Stages 3-4: the sparse coarse surface cells with their levels, sorted by key.
struct SurfaceCells {
    std::vector<CoarseCell> cells;
    std::vector<float> curvature;      ///< per cell (adaptive mode; paper eq. 3)
    std::vector<std::uint8_t> splash;  ///< per cell: within R of a splash particle
    std::vector<std::uint8_t> thin_body;  ///< per cell: no particle inside the fluid in its 3x3x3 block (adaptive mode)
    std::vector<float> particle_kappa; ///< per sorted particle (adaptive mode, when asked for; paper eq. 1)
};
/// `forced_level` 2 or 3 assigns that level to every cell (uniform modes, no curvature pass).
/// `read_particle_kappa`: also copy the per-particle curvature to the host (tests; the pipeline
/// needs only the cells). The curvature kernel writes it only when asked (its keep_kappa
/// argument), so this switch stays in the stage rather than in the tests' library. The curvature pass overwrites `classes.gradient` with the outward unit
/// normals in place (a second array of n normals would be 210 MB at x512); once it has run, the
/// gradients and flags of `classes` are freed (the counts stay).
SurfaceCells surface_cells(OpenCLRuntime& rt, const BinnedParticles& bins, ParticleClasses& classes,
                           float r, float R, float coarse_edge, float threshold, int forced_level,
                           bool read_particle_kappa = false);

/// Stages 5-6: the fine lattice points and their scalar values.
struct FinePoints {
    /// The table is sized to load kTargetLoad of what it must hold and grows only when it would
    /// hold more than kMaxLoad of its slots. The headroom between the two takes the points that the
    /// later passes add (band closure, edge midpoints) without a rehash, which holds both tables at
    /// once. Beyond docs/design.md §5 (load <= 0.5): this table is the largest device allocation, so a
    /// higher load lowers the peak; sized at 0.8, the triangulation's lookups ran slower, while
    /// growing at 0.85 instead of 0.8 spares the ×8 frames the rehash that the level-2 check's and the
    /// edge midpoints' 20% more points caused (bench/RESULTS-implementation.md).
    /// The other tables keep load 0.5.
    static constexpr double kMaxLoad = 0.85;
    static constexpr double kTargetLoad = 0.7;
    DeviceHash hash;      ///< keys in `layout` (4 or 8 bytes a slot)
    DeviceBuffer values;  ///< float per slot; NaN until evaluated
    lattice::KeyLayout layout;  ///< the lattice's (LatticeFrame::keys), taken when the table is made
    std::size_t inserted = 0;
};
/// Which pending points of its cell a work-group claims (kernels/contract.h, CLAIM_*).
using contract::ClaimPoints;
/// Inserts the points of `cells` (growing the table as needed) and evaluates the new ones, in one
/// pass where the table has room. `cube_centres`, empty or one flag per cell: the level-2 cells
/// flagged get the centres of their level-2 cubes too (the level-2 check's points), in the same
/// pass, so that the check costs no insert or lookup pass of its own.
void refine_and_evaluate(OpenCLRuntime& rt, FinePoints& points, const std::vector<CoarseCell>& cells,
                         const LatticeFrame& lattice_frame, const BinnedParticles& bins, float r, float R,
                         const std::vector<std::uint8_t>& cube_centres = {});
/// Edge refinement (tests/reference/edge_refinement.hpp) on the device: inserts and evaluates the midpoints of the
/// level-2 edges of the level-2 cells among `cells` whose ends the surface separates and that the
/// table does not hold yet, in one pass over those cells (each finds its corners in the table,
/// inserts its crossed midpoints and evaluates those it created). Every point of those cells'
/// level must be evaluated already. The host reference is edge_refinement_points.
void refine_edges(OpenCLRuntime& rt, FinePoints& points, const std::vector<CoarseCell>& cells,
                  const LatticeFrame& lattice_frame, const BinnedParticles& bins, float r, float R);
/// The fine-point table mapped for the host (map_fine_points). `view` reads and writes the table
/// itself: no copy on CPU devices (the buffers are allocated host-accessible), and host writes
/// (transition continuity) land in the table. No device stage may touch the table while it is
/// mapped: unmap() first (the guards also unmap when this goes, e.g. when a stage throws).
struct MappedFinePoints {
    MappedBuffer<std::uint8_t> keys;  ///< the key bytes, in the table's layout
    MappedBuffer<float> values;
    FinePointMap view;  ///< empty when nothing was ever inserted (no table) or once unmapped
    /// Ends the map and waits for the queue; OpenCL errors propagate.
    void unmap(OpenCLRuntime& rt);
};
MappedFinePoints map_fine_points(OpenCLRuntime& rt, FinePoints& points);

/// Reads a whole buffer of `count` elements of T.
template <class T>
std::vector<T> read_buffer(OpenCLRuntime& rt, const cl::Buffer& b, std::size_t count) {
    std::vector<T> out(count);
    if (count) rt.queue().enqueueReadBuffer(b, CL_TRUE, 0, count * sizeof(T), out.data());
    return out;
}

}  // namespace trilevel
