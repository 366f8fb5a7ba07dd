#include "opencl_runtime.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string_view>

#include "stage_constants.hpp"

namespace trilevel {

std::string_view embedded_kernel_source(std::string_view name);  // generated at build time

namespace {

// Program sources in dependency order: the hash and the neighbour loop come first.
constexpr const char* kKernelFiles[] = {"hash_table",   "particle_binning", "color_field", "surface_cells",
                                        "curvature",    "refine_points",    "scalar_field"};

std::string type_name(cl_device_type t) {
    if (t & CL_DEVICE_TYPE_GPU) return "GPU";
    if (t & CL_DEVICE_TYPE_CPU) return "CPU";
    if (t & CL_DEVICE_TYPE_ACCELERATOR) return "ACCELERATOR";
    return "OTHER";
}

std::vector<cl::Device> all_devices(std::vector<std::string>* platform_names) {
    std::vector<cl::Platform> platforms;
    if (cl::Platform::get(&platforms) != CL_SUCCESS || platforms.empty())
        throw Error("no OpenCL platform found (install an OpenCL driver, e.g. the Debian package pocl-opencl-icd)");
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
        if (const char* env = std::getenv("TRILEVEL_DEVICE"); env && *env) {
            char* end = nullptr;
            long v = std::strtol(env, &end, 10);
            if (*end != '\0' || v < 0) throw Error(std::string("TRILEVEL_DEVICE='") + env + "' is not a device index");
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

std::string mib(std::uint64_t bytes) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.1f MiB", double(bytes) / double(1 << 20));
    return buf;
}

std::string build_options(std::size_t max_candidates) {
    std::ostringstream o;
    o.precision(9);
    o << "-cl-std=CL1.2 -DMAX_CANDIDATES=" << max_candidates << " -DSURFACE_GRADIENT=" << constants::kSurfaceGradient << "f"
      << " -DSPLASH_NEIGHBOURS=" << constants::kSplashNeighbours
      << " -DTHIN_NEIGHBOURS=" << constants::kThinNeighbours << " -DEV_LOW=" << constants::kEvLow << "f"
      << " -DEV_HIGH=" << constants::kEvHigh << "f";
    return o.str();
}

}  // namespace

std::vector<DeviceInfo> list_devices() {
    std::vector<std::string> platforms;
    auto devices = all_devices(&platforms);
    std::vector<DeviceInfo> out;
    for (std::size_t i = 0; i < devices.size(); ++i) out.push_back(describe(devices[i], int(i), platforms[i]));
    return out;
}

OpenCLRuntime::OpenCLRuntime(int device) {
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
    if (const char* env = std::getenv("TRILEVEL_WORK_GROUP"); env && *env) work_group_ = std::strtoul(env, nullptr, 10);
    // Two float4 lists plus the bin tables and the scalar field's claimed-point list (4 KiB).
    const std::uint64_t local = device_.getInfo<CL_DEVICE_LOCAL_MEM_SIZE>();
    max_candidates_ = std::size_t(std::min<std::uint64_t>(2048, local > 8192 ? (local - 8192) / 32 : 64));
    if (const char* env = std::getenv("TRILEVEL_MAX_CANDIDATES"); env && *env)  // tests: force the fallbacks
        max_candidates_ = std::min<std::size_t>(max_candidates_, std::max(1ul, std::strtoul(env, nullptr, 10)));
    build_program();
}

void OpenCLRuntime::build_program() {
    std::string source;
    for (const char* f : kKernelFiles) source += std::string(embedded_kernel_source(f)) + "\n";
    program_ = cl::Program(context_, source);
    try {
        program_.build(std::vector<cl::Device>{device_}, build_options(max_candidates_).c_str());
    } catch (const cl::Error&) {
        std::string log = program_.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_);
        for (char& c : log)
            if (c == '\n') c = ' ';
        throw Error("OpenCL kernel build failed on '" + info_.name + "': " + log);
    }
}

cl::Kernel& OpenCLRuntime::kernel(const std::string& name) {
    auto it = kernels_.find(name);
    if (it == kernels_.end()) it = kernels_.emplace(name, cl::Kernel(program_, name.c_str())).first;
    return it->second;
}

void OpenCLRuntime::run(const std::string& name, std::size_t global) {
    if (global == 0) return;
    cl::NDRange local = cl::NullRange;
    if (work_group_ > 0) {
        global = (global + work_group_ - 1) / work_group_ * work_group_;
        local = cl::NDRange(work_group_);
    }
    cl::Event ev;
    queue_.enqueueNDRangeKernel(kernel(name), cl::NullRange, cl::NDRange(global), local, nullptr, &ev);
    events_.emplace_back(name, ev);
}

void OpenCLRuntime::run_groups(const std::string& name, std::size_t groups, std::size_t local) {
    if (groups == 0) return;
    cl::Event ev;
    queue_.enqueueNDRangeKernel(kernel(name), cl::NullRange, cl::NDRange(groups * local), cl::NDRange(local), nullptr,
                                &ev);
    events_.emplace_back(name, ev);
}

void OpenCLRuntime::finish() {
    queue_.finish();
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

cl::Buffer OpenCLRuntime::buffer(std::size_t bytes, const char* what, cl_mem_flags flags) {
    bytes = std::max<std::size_t>(bytes, 16);
    if (bytes > info_.max_allocation)
        throw Error(std::string("the ") + what + " needs " + mib(bytes) + " in one buffer, more than '" + info_.name +
                    "' allows (" + mib(info_.max_allocation) +
                    "; PoCL: raise POCL_MEMORY_LIMIT); use a larger cell or a smaller domain");
    if (budget_ && allocated_ + bytes > budget_)
        throw Error(std::string("the ") + what + " would bring device memory to " + mib(allocated_ + bytes) +
                    ", over the budget of " + mib(budget_) +
                    " (--memory-limit or the device's memory); use a larger cell or a smaller domain");
    allocated_ += bytes;
    try {
        return cl::Buffer(context_, flags, bytes);
    } catch (const cl::Error& e) {
        throw Error(std::string("cannot allocate the ") + what + " (" + mib(bytes) +
                    ") on the OpenCL device: " + cl_error_name(e.err()));
    }
}

void OpenCLRuntime::reset_budget(std::uint64_t limit) {
    budget_ = limit ? std::min<std::uint64_t>(limit, info_.global_memory) : info_.global_memory;
    allocated_ = 0;
}

std::string cl_error_name(cl_int code) {
    switch (code) {
        case CL_OUT_OF_RESOURCES: return "CL_OUT_OF_RESOURCES";
        case CL_OUT_OF_HOST_MEMORY: return "CL_OUT_OF_HOST_MEMORY";
        case CL_MEM_OBJECT_ALLOCATION_FAILURE: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
        case CL_INVALID_BUFFER_SIZE: return "CL_INVALID_BUFFER_SIZE";
        case CL_DEVICE_NOT_AVAILABLE: return "CL_DEVICE_NOT_AVAILABLE";
        case CL_BUILD_PROGRAM_FAILURE: return "CL_BUILD_PROGRAM_FAILURE";
        case CL_INVALID_WORK_GROUP_SIZE: return "CL_INVALID_WORK_GROUP_SIZE";
        case CL_INVALID_KERNEL_ARGS: return "CL_INVALID_KERNEL_ARGS";
        default: return "OpenCL error " + std::to_string(code);
    }
}

}  // namespace trilevel
