// The OpenCL device, context, queue and the compiled trilevel program; kernel timing from
// profiling events. One per Reconstructor.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <CL/opencl.hpp>

#include "buffer_pool.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {

class OpenCLRuntime {
public:
    /// device < 0: TRILEVEL_DEVICE, else the first GPU, else the first CPU device.
    /// on_compile: called before a program is compiled from source (Reconstructor's constructor).
    explicit OpenCLRuntime(int device, std::function<void(const KernelCompileNotice&)> on_compile = {});
    /// On a caller's context and device (both retained); `queue` null: a queue of our own on them,
    /// else that queue (retained), which must execute in order.
    OpenCLRuntime(cl_context context, cl_device_id device, cl_command_queue queue);

    const DeviceInfo& info() const { return info_; }
    cl::Context& context() { return context_; }
    cl::CommandQueue& queue() { return queue_; }
    /// Kernel `name` of the program built for the current fine-key width (set_fine_key_bits); the
    /// kernels of device_input.cl come from a program of their own, built on first use.
    cl::Kernel& kernel(const std::string& name);
    /// Whether the device computes in double precision (cl_khr_fp64; device_input.cl needs it).
    bool has_fp64() const { return fp64_; }
    /// Which program the kernels come from: FINE_KEY_BITS 32 (the default, built at start) or 64
    /// (built on first use, for lattices too wide for 32-bit keys: lattice::KeyLayout). Only the
    /// fine-point kernels differ between the two.
    void set_fine_key_bits(int bits);

    /// Candidate particles a work-group gathers into local memory (MAX_CANDIDATES in the kernels):
    /// two float4 lists of them fit the device's local memory (48 KiB on many GPUs), at most 2048.
    std::size_t max_candidates() const { return max_candidates_; }

    /// Work-group size for 1-D launches (run), at most what a kernel allows; 0 lets the driver choose.
    /// TRILEVEL_WORK_GROUP overrides the default, kDefaultWorkGroup: given the choice, PoCL takes the
    /// largest divisor of the global size, which is 1 for a prime particle count: a work-group per
    /// item, unvectorised, each paying a launch (bench/RESULTS-implementation.md).
    static constexpr std::size_t kDefaultWorkGroup = 256;

    /// Enqueues `name` over `global` work-items (rounded up to the work-group size), records its event.
    void run(const std::string& name, std::size_t global);
    /// Enqueues `name` as `groups` work-groups of `local` work-items each.
    void run_groups(const std::string& name, std::size_t groups, std::size_t local);

    /// Waits for the queue and adds the profiled time of every recorded launch to `kernel_ms`.
    void finish();
    std::map<std::string, double> take_kernel_times();

    /// A device buffer of at least `bytes` for the role `what` (also the name in errors), lent
    /// from the buffer pool: reused when a free buffer of the role is large enough, else allocated
    /// (x1.5 growth when a role outgrows its buffer). Checked first against the device's largest
    /// allocation and the budget: the bytes lent at once, this request included, must fit it.
    /// Its content is undefined: fill or write the range the kernels read.
    DeviceBuffer buffer(std::size_t bytes, const char* what, cl_mem_flags flags = CL_MEM_READ_WRITE);

    /// Starts a reconstruction's accounting: `limit` bytes (0: the device's global memory). On CPU
    /// devices, what the pool allocates beyond what it holds now must also fit the RAM available
    /// now (MemAvailable). Pooled buffers over the budget are released.
    void reset_budget(std::uint64_t limit);
    /// Largest number of bytes lent at once since reset_budget: the device memory the run needed
    /// (the pool may hold more: growth slack, buffers of other roles or frames).
    std::uint64_t peak_lent_bytes() const { return peak_lent_; }
    /// End of a frame: trims pooled buffers that stayed oversized or unused (BufferPool::kTrimFrames).
    /// The first frame of a runtime keeps only what is on loan: at each stage and before each
    /// allocation it releases the free buffers, so a single reconstruction holds little more than
    /// its peak_lent_bytes (a one-file CLI run has nothing to reuse them for). From the second
    /// frame on free buffers stay pooled, so a steady sequence allocates nothing after its first.
    void end_frame() { pool_.end_frame(), first_frame_ = false; }
    /// Releases every pooled buffer (buffers still lent go when their DeviceBuffer does).
    void release_buffers() { pool_.clear(); }
    const BufferPool& pool() const { return pool_; }

    /// The pipeline stage now running, named in OpenCL errors ("binning", "scalar_field", ...).
    /// Leaving a stage in which an injected fault was armed but did not fire fires it there.
    void set_stage(const char* stage);
    const std::string& stage() const { return stage_; }
    /// Test hook (TRILEVEL_FAULT=stage): the first launch, wait or allocation in `stage` fails as
    /// if the device had returned CL_OUT_OF_RESOURCES. Empty: no fault.
    void inject_fault(const std::string& stage) { fault_stage_ = stage; }
    /// Whether the program came from the on-disk binary cache (program_cache.hpp), not from source.
    bool program_from_cache() const { return program_from_cache_; }
    /// Wall milliseconds spent building programs since the last call: compiled from source, and
    /// loaded from the cache (each negative when none was). For Stats::time_ms.
    struct ProgramBuildTimes {
        double compiled_ms = -1, loaded_ms = -1;
    };
    ProgramBuildTimes take_program_build_times() { return std::exchange(build_times_, ProgramBuildTimes{}); }
    /// After a failed reconstruction: waits for what is still queued (ignoring errors) and drops the
    /// pending events and timings, and releases the pooled buffers, so the next reconstruction
    /// starts from a clean queue and fresh buffers.
    void recover() noexcept;

private:
    /// The program of fine-key width `bits`: from the on-disk cache when it holds it, else from source.
    /// Bits 0: the device-input program (kernels/device_input.cl).
    cl::Program build_program(int bits);
    void init();  ///< the rest of construction, once device_, context_ and queue_ are set
    std::optional<cl::Program> build_from_binary(std::optional<std::vector<unsigned char>> binary,
                                                 const std::string& options);
    bool serial_gather() const;
    int vector_width() const;
    void maybe_fail(const char* call);
    cl::Buffer allocate(BufferPool::Entry& e, std::size_t bytes, const char* what);
    void make_room(BufferPool::Entry& e, std::size_t& capacity, std::size_t bytes);

    DeviceInfo info_;
    cl::Device device_;
    cl::Context context_;
    cl::CommandQueue queue_;
    std::map<int, cl::Program> programs_;                    ///< by fine-key width
    std::map<std::pair<int, std::string>, cl::Kernel> kernels_;  ///< by fine-key width and name
    int fine_key_bits_ = 32;
    std::vector<std::pair<std::string, cl::Event>> events_;
    std::map<std::string, double> kernel_ms_;
    std::size_t work_group_ = kDefaultWorkGroup;  ///< of 1-D launches (run); see kDefaultWorkGroup
    std::size_t max_candidates_ = 2048;
    bool program_from_cache_ = false;
    std::function<void(const KernelCompileNotice&)> on_compile_;
    ProgramBuildTimes build_times_;
    bool profiling_ = true;  ///< the queue records kernel times (a caller's queue may not)
    bool fp64_ = false;
    BufferPool pool_;
    std::uint64_t budget_ = 0, peak_lent_ = 0;
    std::uint64_t ram_room_ = 0;      ///< CPU devices: MemAvailable at reset_budget (0: no check)
    bool first_frame_ = true;          ///< no frame has ended yet (end_frame)
    std::uint64_t held_at_reset_ = 0; ///< bytes the pool held at reset_budget
    std::string stage_, fault_stage_;
};

/// Device buffers of every runtime in the process that are allocated and not yet released (counted
/// by the OpenCL destructor callback): a leak check for long runs.
std::int64_t live_device_buffers();
/// clCreateBuffer calls of every runtime in the process so far (the pool's allocations).
std::int64_t device_buffer_allocations();

/// MemAvailable of /proc/meminfo in bytes (0 when unknown): the host memory budget.
std::uint64_t available_ram();

/// Human-readable name of an OpenCL error code (CL_OUT_OF_RESOURCES, ...).
std::string cl_error_name(cl_int code);
/// What a user can do about an error code, as "; ..." (empty when there is nothing to say).
std::string cl_error_advice(cl_int code);

}  // namespace trilevel
