#include <chrono>
#include "opencl_runtime.hpp"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string_view>

#include "environment.hpp"
#include "program_cache.hpp"
#include "stage_constants.hpp"

namespace trilevel {

std::string embedded_program_source();       // generated at build time: kernels/kernels.cmake in order
std::string embedded_device_input_source();  // the same, for the device-input program (device_input.cl)

namespace {

std::string type_name(cl_device_type t) {
    if (t & CL_DEVICE_TYPE_GPU) return "GPU";
    if (t & CL_DEVICE_TYPE_CPU) return "CPU";
    if (t & CL_DEVICE_TYPE_ACCELERATOR) return "ACCELERATOR";
    return "OTHER";
}

std::vector<cl::Device> all_devices(std::vector<std::string>* platform_names) {
    std::vector<cl::Platform> platforms;
    cl_int status = CL_SUCCESS;
    try {
        status = cl::Platform::get(&platforms);
    } catch (const cl::Error& e) {  // the ICD loader reports "no platform" as an error code
        status = e.err();
    }
    if (status != CL_SUCCESS || platforms.empty())
        throw Error("no OpenCL platform found (" + (status != CL_SUCCESS ? cl_error_name(status) : std::string("none listed")) +
                    "; install an OpenCL driver, e.g. the Debian package pocl-opencl-icd)");
    std::vector<cl::Device> out;
    for (auto& p : platforms) {
        std::vector<cl::Device> devs;
        try {
            p.getDevices(CL_DEVICE_TYPE_ALL, &devs);
        } catch (const cl::Error&) {
            continue;  // a platform without devices
        }
        for (auto& d : devs) {
            out.push_back(d);
            if (platform_names) platform_names->push_back(p.getInfo<CL_PLATFORM_NAME>());
        }
    }
    if (out.empty()) throw Error("no OpenCL device found on any platform");
    return out;
}

DeviceInfo describe(const cl::Device& d, int index, const std::string& platform) {
    DeviceInfo info;
    info.index = index;
    info.platform = platform;
    info.name = d.getInfo<CL_DEVICE_NAME>();
    info.type = type_name(d.getInfo<CL_DEVICE_TYPE>());
    info.compute_units = d.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
    info.global_memory = d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
    info.max_allocation = d.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
    info.int64_atomics = d.getInfo<CL_DEVICE_EXTENSIONS>().find("cl_khr_int64_base_atomics") != std::string::npos;
    return info;
}

int choose_device(int requested, const std::vector<cl::Device>& devices) {
    if (requested < 0) {
        if (const std::string env = environment().device; !env.empty()) {
            char* end = nullptr;
            long v = std::strtol(env.c_str(), &end, 10);
            if (*end != '\0' || v < 0) throw Error("TRILEVEL_DEVICE='" + env + "' is not a device index");
            requested = int(v);
        }
    }
    if (requested >= 0) {
        if (requested >= int(devices.size()))
            throw Error("OpenCL device " + std::to_string(requested) + " does not exist (" +
                        std::to_string(devices.size()) + " found; see 'trilevel devices')");
        return requested;
    }
    for (std::size_t i = 0; i < devices.size(); ++i)
        if (devices[i].getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_GPU) return int(i);
    for (std::size_t i = 0; i < devices.size(); ++i)
        if (devices[i].getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_CPU) return int(i);
    return 0;
}

std::atomic<std::int64_t> g_live_buffers{0}, g_allocations{0};

void CL_CALLBACK buffer_released(cl_mem, void*) { g_live_buffers.fetch_sub(1, std::memory_order_relaxed); }

std::string mib(std::uint64_t bytes) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.1f MiB", double(bytes) / double(1 << 20));
    return buf;
}

std::string build_options(std::size_t max_candidates, bool cpu, int vector_width) {
    std::ostringstream o;
    o.precision(9);
    o << std::showpoint;  // a float constant of 1 or 0 still reads as an OpenCL float literal ("1.00000000f")
    o << "-cl-std=CL1.2 -DSERIAL_GATHER=" << (cpu ? 1 : 0) << " -DVECTOR_WIDTH=" << vector_width << " -DMAX_CANDIDATES=" << max_candidates << " -DSURFACE_GRADIENT=" << constants::kSurfaceGradient << "f"
      << " -DSPLASH_NEIGHBOURS=" << constants::kSplashNeighbours
      << " -DTHIN_NEIGHBOURS=" << constants::kThinNeighbours << " -DSAME_SPOT=" << constants::kSameSpot << "f"
      << " -DPILE_FRACTION=" << constants::kPileFraction << "f" << " -DEV_LOW=" << constants::kEvLow << "f"
      << " -DEV_HIGH=" << constants::kEvHigh << "f" << " -DSUPPORT_CUT=" << constants::kSupportCut << "f";
    return o.str();
}

}  // namespace

std::vector<DeviceInfo> list_devices() try {
    std::vector<std::string> platforms;
    auto devices = all_devices(&platforms);
    std::vector<DeviceInfo> out;
    for (std::size_t i = 0; i < devices.size(); ++i) out.push_back(describe(devices[i], int(i), platforms[i]));
    return out;
} catch (const cl::Error& e) {
    throw Error(std::string("cannot list OpenCL devices: ") + e.what() + " returned " + cl_error_name(e.err()));
}

OpenCLRuntime::OpenCLRuntime(int device, std::function<void(const KernelCompileNotice&)> on_compile) try
    : on_compile_(std::move(on_compile)) {
    std::vector<std::string> platforms;
    auto devices = all_devices(&platforms);
    int idx = choose_device(device, devices);
    device_ = devices[idx];
    info_ = describe(device_, idx, platforms[idx]);
    if (!info_.int64_atomics)
        throw Error("OpenCL device '" + info_.name + "' lacks cl_khr_int64_base_atomics, which the fine-point hash needs");
    try {
        context_ = cl::Context(device_);
        queue_ = cl::CommandQueue(context_, device_, CL_QUEUE_PROFILING_ENABLE);
    } catch (const cl::Error& e) {
        throw Error("cannot open OpenCL device '" + info_.name + "': " + e.what() + " " + cl_error_name(e.err()));
    }
    init();
} catch (const cl::Error& e) {
    throw Error(std::string("cannot set up the OpenCL device: ") + e.what() + " returned " + cl_error_name(e.err()));
}

OpenCLRuntime::OpenCLRuntime(cl_context context, cl_device_id device, cl_command_queue queue) try {
    if (!context) throw Error("no OpenCL context given (null cl_context)");
    if (!device) throw Error("no OpenCL device given (null cl_device_id)");
    context_ = cl::Context(context, true);  // retain: ours until the runtime goes
    device_ = cl::Device(device, true);
    const auto in_context = context_.getInfo<CL_CONTEXT_DEVICES>();
    if (std::none_of(in_context.begin(), in_context.end(), [&](const cl::Device& d) { return d() == device; }))
        throw Error("the OpenCL device is not one of the given context's devices");
    const cl::Platform platform(device_.getInfo<CL_DEVICE_PLATFORM>());
    int index = -1;  // its place in `trilevel devices`, if the ICD loader lists it
    try {
        const auto all = all_devices(nullptr);
        for (std::size_t i = 0; i < all.size(); ++i)
            if (all[i]() == device) index = int(i);
    } catch (const Error&) {
    }
    info_ = describe(device_, index, platform.getInfo<CL_PLATFORM_NAME>());
    if (!info_.int64_atomics)
        throw Error("OpenCL device '" + info_.name + "' lacks cl_khr_int64_base_atomics, which the fine-point hash needs");
    if (queue) {
        queue_ = cl::CommandQueue(queue, true);
        if (queue_.getInfo<CL_QUEUE_CONTEXT>()() != context || queue_.getInfo<CL_QUEUE_DEVICE>()() != device)
            throw Error("the OpenCL command queue belongs to another context or device than those given");
        const cl_command_queue_properties props = queue_.getInfo<CL_QUEUE_PROPERTIES>();
        // Stages enqueue one after the other and rely on the queue's order.
        if (props & CL_QUEUE_OUT_OF_ORDER_EXEC_MODE_ENABLE)
            throw Error("the OpenCL command queue executes out of order; give an in-order queue (or none: one is made)");
        profiling_ = (props & CL_QUEUE_PROFILING_ENABLE) != 0;
    } else {
        queue_ = cl::CommandQueue(context_, device_, CL_QUEUE_PROFILING_ENABLE);
    }
    init();
} catch (const cl::Error& e) {
    throw Error(std::string("cannot set up the given OpenCL device: ") + e.what() + " returned " + cl_error_name(e.err()));
}

void OpenCLRuntime::init() {
    fp64_ = device_.getInfo<CL_DEVICE_EXTENSIONS>().find("cl_khr_fp64") != std::string::npos;
    work_group_ = std::min(work_group_, device_.getInfo<CL_DEVICE_MAX_WORK_GROUP_SIZE>());
    const EnvironmentOverrides env = environment();
    if (env.work_group) work_group_ = *env.work_group;
    // 32 bytes a candidate: two float4 lists (or one and the scalar field's three float columns),
    // plus the bin tables and the scalar field's claimed-point list (4 KiB).
    const std::uint64_t local = device_.getInfo<CL_DEVICE_LOCAL_MEM_SIZE>();
    max_candidates_ = std::size_t(std::min<std::uint64_t>(2048, local > 8192 ? (local - 8192) / 32 : 64));
    if (env.max_candidates) max_candidates_ = std::min(max_candidates_, *env.max_candidates);  // tests: force the fallbacks
    programs_.emplace(32, build_program(32));
}

/// gather_candidates (particle_binning.cl): one work-item copies on CPU devices, all of them on
/// others. TRILEVEL_SERIAL_GATHER=0|1 overrides it (tests: both give the same bits).
bool OpenCLRuntime::serial_gather() const {
    if (const std::optional<bool> serial = environment().serial_gather) return *serial;
    return (device_.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_CPU) != 0;
}

/// The lanes of the vectors in scalar_field_cells (points a work-item evaluates at once) and
/// color_field (16: a bin and its +x neighbour in one vector), VECTOR_WIDTH in the kernels: 16 on CPU
/// devices that prefer 16-wide float vectors (AVX-512: per lane, a 16-wide FMA runs at 1.6x the
/// rate of an 8-wide one), else 8. TRILEVEL_VECTOR_WIDTH=8|16 overrides it (tests: both give the
/// same bits).
int OpenCLRuntime::vector_width() const {
    if (const std::optional<int> lanes = environment().vector_width) return *lanes;
    const bool cpu = (device_.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_CPU) != 0;
    return cpu && device_.getInfo<CL_DEVICE_PREFERRED_VECTOR_WIDTH_FLOAT>() >= 16 ? 16 : 8;
}

/// The program from a cached binary, if there is one and the driver takes it.
std::optional<cl::Program> OpenCLRuntime::build_from_binary(std::optional<std::vector<unsigned char>> binary,
                                                            const std::string& options) {
    if (!binary) return std::nullopt;
    try {
        cl::Program program(context_, {device_}, cl::Program::Binaries{std::move(*binary)});
        program.build(std::vector<cl::Device>{device_}, options.c_str());
        return program;
    } catch (const cl::Error&) {
        return std::nullopt;
    }
}

cl::Program OpenCLRuntime::build_program(int bits) {
    const auto start = std::chrono::steady_clock::now();
    const auto add_time = [&](double& total) {
        total = std::max(total, 0.0) + std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    };
    // bits == 0: the device-input program of its own (it needs double precision, the main one does not)
    const std::string source = bits == 0 ? embedded_device_input_source() : embedded_program_source();
    const std::string options = bits == 0 ? std::string("-cl-std=CL1.2")
                                          : build_options(max_candidates_, serial_gather(), vector_width()) + " -DFINE_KEY_BITS=" + std::to_string(bits);
    // The cached binary of exactly this source, these options and this device and driver, if any
    // (program_cache.hpp); one the driver rejects is rebuilt from source and replaced.
    const std::string dir = program_cache_dir();
    std::string name, path;
    if (!dir.empty()) {
        const cl::Platform platform(device_.getInfo<CL_DEVICE_PLATFORM>());
        name = program_cache_name({source, options, info_.name, device_.getInfo<CL_DEVICE_VERSION>(),
                                   device_.getInfo<CL_DRIVER_VERSION>(), platform.getInfo<CL_PLATFORM_NAME>(),
                                   platform.getInfo<CL_PLATFORM_VERSION>()});
        path = program_cache_path(dir, name);
        if (auto cached = build_from_binary(load_program_binary(path, name), options)) {
            if (bits == 32) program_from_cache_ = true;
            add_time(build_times_.loaded_ms);
            return *cached;
        }
    }
    if (on_compile_) on_compile_({info_.name, dir});  // seconds follow: say why
    cl::Program program(context_, source);
    try {
        program.build(std::vector<cl::Device>{device_}, options.c_str());
    } catch (const cl::Error&) {
        std::string log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_);
        for (char& c : log)
            if (c == '\n') c = ' ';
        throw Error("OpenCL kernel build failed on '" + info_.name + "': " + log);
    }
    if (!path.empty()) {
        const auto binaries = program.getInfo<CL_PROGRAM_BINARIES>();
        if (binaries.size() == 1 && !binaries[0].empty() && store_program_binary(path, name, binaries[0]))
            prune_program_cache(dir, program_cache_max_bytes(), name);
    }
    add_time(build_times_.compiled_ms);
    return program;
}

void OpenCLRuntime::set_fine_key_bits(int bits) {
    if (bits != 32 && bits != 64) throw Error("internal: fine keys are 32 or 64 bits, not " + std::to_string(bits));
    fine_key_bits_ = bits;
}

cl::Kernel& OpenCLRuntime::kernel(const std::string& name) {
    const bool input = name == "positions_bounds" || name == "gather_positions";  // device_input.cl
    const auto id = std::make_pair(input ? 0 : fine_key_bits_, name);
    auto it = kernels_.find(id);
    if (it != kernels_.end()) return it->second;
    auto program = programs_.find(id.first);
    if (program == programs_.end()) program = programs_.emplace(id.first, build_program(id.first)).first;
    return kernels_.emplace(id, cl::Kernel(program->second, name.c_str())).first->second;
}

void OpenCLRuntime::set_stage(const char* stage) {
    if (!fault_stage_.empty() && fault_stage_ == stage_) maybe_fail("clFinish");  // armed, never fired
    stage_ = stage;
    if (first_frame_) pool_.release_free(false);  // end_frame: a first frame keeps only its loans
}

void OpenCLRuntime::maybe_fail(const char* call) {
    if (fault_stage_.empty() || fault_stage_ != stage_) return;
    fault_stage_.clear();  // one fault per arming
    throw cl::Error(CL_OUT_OF_RESOURCES, call);
}

void OpenCLRuntime::recover() noexcept {
    try {
        queue_.finish();
    } catch (...) {  // the queue may be what failed; its commands are gone either way
    }
    events_.clear();
    kernel_ms_.clear();
    pool_.clear();  // buffers of a failed frame may hold anything, and the failure may be memory
    stage_.clear();
    fault_stage_.clear();
}

std::uint64_t available_ram() {
    std::uint64_t avail = 0;
    if (std::FILE* f = std::fopen("/proc/meminfo", "r")) {
        char line[256];
        unsigned long long kb = 0;
        while (std::fgets(line, sizeof(line), f))
            if (std::sscanf(line, "MemAvailable: %llu kB", &kb) == 1) avail = std::uint64_t(kb) * 1024;
        std::fclose(f);
    }
    return avail;
}

std::int64_t live_device_buffers() { return g_live_buffers.load(std::memory_order_relaxed); }
std::int64_t device_buffer_allocations() { return g_allocations.load(std::memory_order_relaxed); }

void OpenCLRuntime::run(const std::string& name, std::size_t global) {
    maybe_fail("clEnqueueNDRangeKernel");
    if (global == 0) return;
    cl::NDRange local = cl::NullRange;
    std::size_t w = work_group_;
    if (w > 0) {  // within the kernel's own limit (a GPU may allow less for a kernel than for the device)
        const std::size_t limit = kernel(name).getWorkGroupInfo<CL_KERNEL_WORK_GROUP_SIZE>(device_);
        while (w > limit && w > 1) w /= 2;
        global = (global + w - 1) / w * w;
        local = cl::NDRange(w);
    }
    cl::Event ev;
    queue_.enqueueNDRangeKernel(kernel(name), cl::NullRange, cl::NDRange(global), local, nullptr, &ev);
    events_.emplace_back(name, ev);
}

void OpenCLRuntime::run_groups(const std::string& name, std::size_t groups, std::size_t local) {
    maybe_fail("clEnqueueNDRangeKernel");
    if (groups == 0) return;
    cl::Event ev;
    queue_.enqueueNDRangeKernel(kernel(name), cl::NullRange, cl::NDRange(groups * local), cl::NDRange(local), nullptr,
                                &ev);
    events_.emplace_back(name, ev);
}

void OpenCLRuntime::finish() {
    maybe_fail("clFinish");
    queue_.finish();
    if (!profiling_) events_.clear();  // a caller's queue without profiling: no kernel times
    for (auto& [name, ev] : events_) {
        auto start = ev.getProfilingInfo<CL_PROFILING_COMMAND_START>();
        auto end = ev.getProfilingInfo<CL_PROFILING_COMMAND_END>();
        kernel_ms_[name] += double(end - start) * 1e-6;
    }
    events_.clear();
}

std::map<std::string, double> OpenCLRuntime::take_kernel_times() {
    finish();
    return std::exchange(kernel_ms_, {});
}

DeviceBuffer OpenCLRuntime::buffer(std::size_t bytes, const char* what, cl_mem_flags flags) {
    bytes = std::max<std::size_t>(bytes, 16);
    if (bytes > info_.max_allocation)
        throw Error(std::string("the ") + what + " needs " + mib(bytes) + " in one buffer, more than '" + info_.name +
                    "' allows (" + mib(info_.max_allocation) +
                    "; PoCL: raise POCL_MEMORY_LIMIT); use a larger cell or a smaller domain");
    // The budget bounds what the run holds at once (deterministic, whatever the pool kept from
    // earlier frames), so a frame fits a --memory-limit of its own Stats::device_memory_bytes.
    const std::uint64_t lent = pool_.lent_bytes() + bytes;
    if (budget_ && lent > budget_)
        throw Error(std::string("the ") + what + " would bring device memory to " + mib(lent) +
                    ", over the budget of " + mib(budget_) +
                    " (--memory-limit or the device's memory); use a larger cell or a smaller domain");
    maybe_fail("clCreateBuffer");
    peak_lent_ = std::max(peak_lent_, lent);
    BufferPool::Entry& e = pool_.find(what, flags, bytes);
    if (e.capacity < bytes) {
        std::size_t capacity = e.capacity ? std::max(bytes, std::size_t(double(e.capacity) * BufferPool::kGrowth)) : bytes;
        capacity = std::min<std::size_t>(capacity, info_.max_allocation);
        if (first_frame_) pool_.release_free(false, &e);  // end_frame: a first frame keeps only its loans
        make_room(e, capacity, bytes);
        pool_.drop(e);  // before allocating its successor: the old buffer's memory is free first
        pool_.install(e, allocate(e, capacity, what), capacity);
    }
    return pool_.lend(e, bytes);
}

/// Keeps what the pool holds within the budget (and, on CPU devices, the RAM available) when `e`
/// grows to `capacity`: releases free buffers not used this frame, then any free buffer, then
/// gives up the growth slack. Past that only the RAM check fails (the budget check on what is
/// lent has passed; the excess is the slack of buffers on loan).
void OpenCLRuntime::make_room(BufferPool::Entry& e, std::size_t& capacity, std::size_t bytes) {
    auto over = [&] {
        const std::uint64_t held = pool_.held_bytes() - e.capacity + capacity;
        return (budget_ && held > budget_) || (ram_room_ && held > held_at_reset_ + ram_room_);
    };
    if (over()) pool_.release_free(true, &e);
    if (over()) pool_.release_free(false, &e);
    if (over()) capacity = bytes;
    const std::uint64_t held = pool_.held_bytes() - e.capacity + capacity;
    // A CPU device's buffers are host memory: past the RAM that was available, the kernel's OOM
    // killer would end the process instead of this error.
    if (ram_room_ && held > held_at_reset_ + ram_room_)
        throw Error(std::string("the ") + e.role + " (" + mib(bytes) + ") would bring the device buffers of this CPU device to " +
                    mib(held) + ", over the " + mib(held_at_reset_ + ram_room_) +
                    " of RAM available; use a larger cell or a smaller domain");
}

cl::Buffer OpenCLRuntime::allocate(BufferPool::Entry& e, std::size_t bytes, const char* what) {
    for (int attempt = 0;; ++attempt) {
        try {
            cl::Buffer b(context_, e.flags, bytes);
            g_allocations.fetch_add(1, std::memory_order_relaxed);
            g_live_buffers.fetch_add(1, std::memory_order_relaxed);
            if (clSetMemObjectDestructorCallback(b(), buffer_released, nullptr) != CL_SUCCESS)
                g_live_buffers.fetch_sub(1, std::memory_order_relaxed);  // not counted, rather than a false leak
            return b;
        } catch (const cl::Error& e2) {
            // The device's own limit may lie below the budget: free buffers of the pool first.
            if (attempt == 0 && pool_.release_free(false, &e) > 0) continue;
            throw Error(std::string("cannot allocate the ") + what + " (" + mib(bytes) +
                        ") on the OpenCL device: " + cl_error_name(e2.err()));
        }
    }
}

void OpenCLRuntime::reset_budget(std::uint64_t limit) {
    budget_ = limit ? std::min<std::uint64_t>(limit, info_.global_memory) : info_.global_memory;
    if (pool_.held_bytes() > budget_) pool_.release_free(false);  // a lower limit than before
    ram_room_ = info_.type == "CPU" ? available_ram() : 0;
    held_at_reset_ = pool_.held_bytes();
    peak_lent_ = 0;
}

std::string cl_error_advice(cl_int code) {
    switch (code) {
        case CL_OUT_OF_RESOURCES:
        case CL_MEM_OBJECT_ALLOCATION_FAILURE:
        case CL_OUT_OF_HOST_MEMORY:
            return "; the device ran out of memory or resources: use a larger cell or a smaller domain";
        case CL_DEVICE_NOT_AVAILABLE:
        case -9999:  // NVIDIA: illegal address, the device is lost
            return "; the device was lost or is busy: check the driver, or pick another one with --device";
        default: return "";
    }
}

std::string cl_error_name(cl_int code) {
    switch (code) {
#define TRILEVEL_CL_ERROR(name) \
    case name: return #name;
        TRILEVEL_CL_ERROR(CL_DEVICE_NOT_FOUND)
        TRILEVEL_CL_ERROR(CL_DEVICE_NOT_AVAILABLE)
        TRILEVEL_CL_ERROR(CL_COMPILER_NOT_AVAILABLE)
        TRILEVEL_CL_ERROR(CL_MEM_OBJECT_ALLOCATION_FAILURE)
        TRILEVEL_CL_ERROR(CL_OUT_OF_RESOURCES)
        TRILEVEL_CL_ERROR(CL_OUT_OF_HOST_MEMORY)
        TRILEVEL_CL_ERROR(CL_PROFILING_INFO_NOT_AVAILABLE)
        TRILEVEL_CL_ERROR(CL_MEM_COPY_OVERLAP)
        TRILEVEL_CL_ERROR(CL_BUILD_PROGRAM_FAILURE)
        TRILEVEL_CL_ERROR(CL_MAP_FAILURE)
        TRILEVEL_CL_ERROR(CL_MISALIGNED_SUB_BUFFER_OFFSET)
        TRILEVEL_CL_ERROR(CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST)
        TRILEVEL_CL_ERROR(CL_INVALID_VALUE)
        TRILEVEL_CL_ERROR(CL_INVALID_DEVICE_TYPE)
        TRILEVEL_CL_ERROR(CL_INVALID_PLATFORM)
        TRILEVEL_CL_ERROR(CL_INVALID_DEVICE)
        TRILEVEL_CL_ERROR(CL_INVALID_CONTEXT)
        TRILEVEL_CL_ERROR(CL_INVALID_QUEUE_PROPERTIES)
        TRILEVEL_CL_ERROR(CL_INVALID_COMMAND_QUEUE)
        TRILEVEL_CL_ERROR(CL_INVALID_HOST_PTR)
        TRILEVEL_CL_ERROR(CL_INVALID_MEM_OBJECT)
        TRILEVEL_CL_ERROR(CL_INVALID_BINARY)
        TRILEVEL_CL_ERROR(CL_INVALID_BUILD_OPTIONS)
        TRILEVEL_CL_ERROR(CL_INVALID_PROGRAM)
        TRILEVEL_CL_ERROR(CL_INVALID_PROGRAM_EXECUTABLE)
        TRILEVEL_CL_ERROR(CL_INVALID_KERNEL_NAME)
        TRILEVEL_CL_ERROR(CL_INVALID_KERNEL)
        TRILEVEL_CL_ERROR(CL_INVALID_ARG_INDEX)
        TRILEVEL_CL_ERROR(CL_INVALID_ARG_VALUE)
        TRILEVEL_CL_ERROR(CL_INVALID_ARG_SIZE)
        TRILEVEL_CL_ERROR(CL_INVALID_KERNEL_ARGS)
        TRILEVEL_CL_ERROR(CL_INVALID_WORK_DIMENSION)
        TRILEVEL_CL_ERROR(CL_INVALID_WORK_GROUP_SIZE)
        TRILEVEL_CL_ERROR(CL_INVALID_WORK_ITEM_SIZE)
        TRILEVEL_CL_ERROR(CL_INVALID_GLOBAL_OFFSET)
        TRILEVEL_CL_ERROR(CL_INVALID_EVENT_WAIT_LIST)
        TRILEVEL_CL_ERROR(CL_INVALID_EVENT)
        TRILEVEL_CL_ERROR(CL_INVALID_OPERATION)
        TRILEVEL_CL_ERROR(CL_INVALID_BUFFER_SIZE)
        TRILEVEL_CL_ERROR(CL_INVALID_GLOBAL_WORK_SIZE)
#undef TRILEVEL_CL_ERROR
        case -1001: return "CL_PLATFORM_NOT_FOUND_KHR";
        default: return "OpenCL error " + std::to_string(code);
    }
}

}  // namespace trilevel
