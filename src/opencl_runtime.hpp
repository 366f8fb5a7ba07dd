// The OpenCL device, context, queue and the compiled trilevel program; kernel timing from
// profiling events. One per Reconstructor.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <CL/opencl.hpp>

#include "trilevel/trilevel.hpp"

namespace trilevel {

class OpenCLRuntime {
public:
    /// device < 0: TRILEVEL_DEVICE, else the first GPU, else the first CPU device.
    explicit OpenCLRuntime(int device);

    const DeviceInfo& info() const { return info_; }
    cl::Context& context() { return context_; }
    cl::CommandQueue& queue() { return queue_; }
    cl::Kernel& kernel(const std::string& name);

    /// Candidate particles a work-group gathers into local memory (MAX_CANDIDATES in the kernels):
    /// two float4 lists of them fit the device's local memory (48 KiB on many GPUs), at most 2048.
    std::size_t max_candidates() const { return max_candidates_; }

    /// Work-group size for 1-D launches; 0 lets the driver choose (TRILEVEL_WORK_GROUP overrides).
    std::size_t work_group_size() const { return work_group_; }
    void set_work_group_size(std::size_t w) { work_group_ = w; }

    /// Enqueues `name` over `global` work-items (rounded up to the work-group size), records its event.
    void run(const std::string& name, std::size_t global);
    /// Enqueues `name` as `groups` work-groups of `local` work-items each.
    void run_groups(const std::string& name, std::size_t groups, std::size_t local);

    /// Waits for the queue and adds the profiled time of every recorded launch to `kernel_ms`.
    void finish();
    std::map<std::string, double> take_kernel_times();

    /// A device buffer of `bytes`, checked against the device's limits and the memory budget first.
    cl::Buffer buffer(std::size_t bytes, const char* what, cl_mem_flags flags = CL_MEM_READ_WRITE);

    /// Starts a reconstruction's accounting: `limit` bytes (0: the device's global memory). On CPU
    /// devices the buffers held at once must also fit the RAM available now (MemAvailable).
    void reset_budget(std::uint64_t limit);
    /// Bytes of device buffers allocated since reset_budget (an upper bound of what is held).
    std::uint64_t allocated_bytes() const { return allocated_; }

    /// The pipeline stage now running, named in OpenCL errors ("binning", "scalar_field", ...).
    /// Leaving a stage in which an injected fault was armed but did not fire fires it there.
    void set_stage(const char* stage);
    const std::string& stage() const { return stage_; }
    /// Test hook (TRILEVEL_FAULT=stage): the first launch, wait or allocation in `stage` fails as
    /// if the device had returned CL_OUT_OF_RESOURCES. Empty: no fault.
    void inject_fault(const std::string& stage) { fault_stage_ = stage; }
    /// After a failed reconstruction: waits for what is still queued (ignoring errors) and drops the
    /// pending events and timings, so the next reconstruction starts from a clean queue.
    void recover() noexcept;

private:
    void build_program();
    void maybe_fail(const char* call);

    DeviceInfo info_;
    cl::Device device_;
    cl::Context context_;
    cl::CommandQueue queue_;
    cl::Program program_;
    std::map<std::string, cl::Kernel> kernels_;
    std::vector<std::pair<std::string, cl::Event>> events_;
    std::map<std::string, double> kernel_ms_;
    std::size_t work_group_ = 0;
    std::size_t max_candidates_ = 2048;
    std::uint64_t budget_ = 0, allocated_ = 0;
    std::uint64_t ram_room_ = 0;     ///< CPU devices: MemAvailable at reset_budget (0: no check)
    std::int64_t live_at_reset_ = 0; ///< live device bytes of the process at reset_budget
    std::string stage_, fault_stage_;
};

/// Device buffers of every runtime in the process that are allocated and not yet released (counted
/// by the OpenCL destructor callback): a leak check for long runs.
std::int64_t live_device_buffers();

/// MemAvailable of /proc/meminfo in bytes (0 when unknown): the host memory budget.
std::uint64_t available_ram();

/// Human-readable name of an OpenCL error code (CL_OUT_OF_RESOURCES, ...).
std::string cl_error_name(cl_int code);
/// What a user can do about an error code, as "; ..." (empty when there is nothing to say).
std::string cl_error_advice(cl_int code);

}  // namespace trilevel
