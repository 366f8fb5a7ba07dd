// Frames per second of one OpenCL device, inside one process, the way a simulator or a render
// farm job meshes a sequence: no process start, no kernel compile, no file I/O in the timed loop.
//
//   device_frames --device D [--threads N] [--frames K] [--radius R] [--json OUT] FILE...
//
// The files are read once and cycled through as K frames (frame i is file i mod count). Three
// ways to mesh them, each on a fresh Reconstructor of device D after one untimed warm-up frame:
//   host      Reconstructor::reconstruct(const float*, ...), one frame after the other;
//   device    positions in a cl_mem of a context the program makes itself, as a GPU simulator
//             holds them (Reconstructor(context, device, queue) and reconstruct(DevicePositions));
//             every mesh must be bit-identical to the host loop's mesh of the same frame;
//   pipeline  FramePipeline: the caller copies frame k+1 while frame k is meshed and frame k-1 is
//             handed to the sink (which drops it, as a writer that keeps up would).
// Prints, per way: the Reconstructor's construction (context, program load), the median per-frame
// wall time of the call and the library's Stats "total", frames per second over the loop, and the
// median of each stage. --json writes the same numbers. Exits non-zero when a device mesh differs
// from the host one or a mesh is not closed.
#include <CL/cl.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "trilevel/io.hpp"
#include "trilevel/pipeline.hpp"
#include "trilevel/trilevel.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double stage(const trilevel::Stats& s, const std::string& name) {
    for (const auto& [k, v] : s.time_ms)
        if (k == name) return v;
    return 0.0;
}

/// What one way of meshing measured.
struct Result {
    std::string way;
    double construct_ms = 0.0;       // the Reconstructor's constructor (context or program load)
    std::vector<double> call_ms;     // wall time of each timed frame's call
    std::vector<double> total_ms;    // Stats "total" of each timed frame
    std::map<std::string, std::vector<double>> stages;
    double loop_ms = 0.0;            // the whole timed loop
    std::size_t frames = 0;
    std::size_t triangles = 0;       // of the last frame
    void add(const trilevel::Stats& s, double call) {
        call_ms.push_back(call);
        total_ms.push_back(stage(s, "total"));
        for (const auto& [k, v] : s.time_ms)
            if (k != "total" && k != "kernel_load" && k != "kernel_compile") stages[k].push_back(v);
        triangles = s.triangles;
    }
    double fps() const { return loop_ms > 0 ? 1000.0 * double(frames) / loop_ms : 0.0; }
};

bool same(const trilevel::Mesh& a, const trilevel::Mesh& b) {
    return a.positions == b.positions && a.triangles == b.triangles;
}

/// A simulator's OpenCL objects on the device of global index `index` (as `trilevel devices`).
struct SimulatorContext {
    cl_device_id device = nullptr;
    cl_context context = nullptr;
    cl_command_queue queue = nullptr;
    std::vector<cl_mem> buffers;

    explicit SimulatorContext(int index) {
        cl_uint np = 0;
        clGetPlatformIDs(0, nullptr, &np);
        std::vector<cl_platform_id> platforms(np);
        clGetPlatformIDs(np, platforms.data(), nullptr);
        int seen = 0;
        for (cl_platform_id p : platforms) {
            cl_uint nd = 0;
            if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 0, nullptr, &nd) != CL_SUCCESS) continue;
            std::vector<cl_device_id> ds(nd);
            clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, nd, ds.data(), nullptr);
            for (cl_device_id d : ds)
                if (seen++ == index) device = d;
        }
        if (!device) throw std::runtime_error("no OpenCL device " + std::to_string(index));
        cl_int err = CL_SUCCESS;
        context = clCreateContext(nullptr, 1, &device, nullptr, nullptr, &err);
        if (err != CL_SUCCESS) throw std::runtime_error("clCreateContext failed: " + std::to_string(err));
        queue = clCreateCommandQueueWithProperties(context, device, nullptr, &err);
        if (err != CL_SUCCESS) throw std::runtime_error("clCreateCommandQueue failed: " + std::to_string(err));
    }
    ~SimulatorContext() {
        for (cl_mem b : buffers) clReleaseMemObject(b);
        clReleaseCommandQueue(queue);
        clReleaseContext(context);
    }
    cl_mem upload(const std::vector<float>& xyz) {
        cl_int err = CL_SUCCESS;
        cl_mem b = clCreateBuffer(context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, xyz.size() * sizeof(float),
                                  const_cast<float*>(xyz.data()), &err);
        if (err != CL_SUCCESS) throw std::runtime_error("clCreateBuffer failed: " + std::to_string(err));
        buffers.push_back(b);
        return b;
    }
};

void print(const Result& r) {
    std::printf("%-9s construct %7.1f ms | per frame: call %7.1f ms, library total %7.1f ms | %6.2f frames/s over %zu frames | %zu triangles\n",
                r.way.c_str(), r.construct_ms, median(r.call_ms), median(r.total_ms), r.fps(), r.frames, r.triangles);
    std::printf("          stages (median ms):");
    for (const auto& [k, v] : r.stages) std::printf(" %s %.1f,", k.c_str(), median(v));
    std::printf("\n");
}

std::string json(const Result& r) {
    std::string s = "{\"way\": \"" + r.way + "\", \"construct_ms\": " + std::to_string(r.construct_ms) +
                    ", \"call_ms_median\": " + std::to_string(median(r.call_ms)) +
                    ", \"total_ms_median\": " + std::to_string(median(r.total_ms)) +
                    ", \"frames\": " + std::to_string(r.frames) + ", \"fps\": " + std::to_string(r.fps()) +
                    ", \"triangles\": " + std::to_string(r.triangles) + ", \"stages_ms_median\": {";
    bool first = true;
    for (const auto& [k, v] : r.stages) {
        s += (first ? "\"" : ", \"") + k + "\": " + std::to_string(median(v));
        first = false;
    }
    return s + "}}";
}

}  // namespace

int main(int argc, char** argv) {
    int device = -1, frames = 10, threads = 0;
    float radius = 0.0f;
    std::string json_path;
    std::vector<std::string> files;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> std::string {
            if (i + 1 >= argc) { std::fprintf(stderr, "device_frames: %s needs a value\n", a.c_str()); std::exit(2); }
            return argv[++i];
        };
        if (a == "--device") device = std::stoi(next());
        else if (a == "--frames") frames = std::stoi(next());
        else if (a == "--threads") threads = std::stoi(next());
        else if (a == "--radius") radius = std::stof(next());
        else if (a == "--json") json_path = next();
        else files.push_back(a);
    }
    if (files.empty() || radius <= 0.0f || device < 0 || frames < 1) {
        std::fprintf(stderr, "usage: device_frames --device D --radius R [--threads N] [--frames K] [--json OUT] FILE...\n");
        return 2;
    }
    std::optional<tbb::global_control> limit;
    if (threads > 0) {
        ::setenv("POCL_MAX_PTHREAD_COUNT", std::to_string(threads).c_str(), 1);  // read when PoCL starts
        limit.emplace(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    }
    try {
        std::vector<std::vector<float>> inputs;
        for (const auto& f : files) inputs.push_back(trilevel::read_particles(f).positions);
        trilevel::Params params;
        params.particle_radius = radius;
        params.level_hysteresis = 0.2f;  // the CLI's default for sequences
        auto frame = [&](int i) -> const std::vector<float>& { return inputs[std::size_t(i) % inputs.size()]; };

        std::vector<Result> results;
        std::vector<trilevel::Mesh> host_meshes;
        bool ok = true;

        {  // host arrays, one frame after the other
            Result r{"host"};
            auto t0 = Clock::now();
            trilevel::Reconstructor rec(device);
            r.construct_ms = ms_since(t0);
            std::printf("device: %s\n", rec.device().name.c_str());
            rec.reconstruct(frame(0).data(), frame(0).size() / 3, params);  // warm-up
            rec.reset_history();
            const auto loop = Clock::now();
            for (int i = 0; i < frames; ++i) {
                trilevel::Stats s;
                const auto c = Clock::now();
                host_meshes.push_back(rec.reconstruct(frame(i).data(), frame(i).size() / 3, params, &s));
                r.add(s, ms_since(c));
                ok = ok && s.closed;
            }
            r.loop_ms = ms_since(loop);
            r.frames = std::size_t(frames);
            results.push_back(r);
        }
        {  // a simulator's cl_mem, no host round trip
            Result r{"device"};
            SimulatorContext sim(device);
            std::vector<cl_mem> bufs;
            for (const auto& in : inputs) bufs.push_back(sim.upload(in));
            clFinish(sim.queue);
            auto t0 = Clock::now();
            trilevel::Reconstructor rec(sim.context, sim.device, sim.queue);
            r.construct_ms = ms_since(t0);
            auto positions = [&](int i) {
                trilevel::DevicePositions p;
                p.buffer = bufs[std::size_t(i) % bufs.size()];
                p.count = frame(i).size() / 3;
                return p;
            };
            rec.reconstruct(positions(0), params);  // warm-up
            rec.reset_history();
            const auto loop = Clock::now();
            for (int i = 0; i < frames; ++i) {
                trilevel::Stats s;
                const auto c = Clock::now();
                const trilevel::Mesh m = rec.reconstruct(positions(i), params, &s);
                r.add(s, ms_since(c));
                if (!same(m, host_meshes[std::size_t(i)])) {
                    std::printf("frame %d: the device path's mesh differs from the host path's\n", i);
                    ok = false;
                }
            }
            r.loop_ms = ms_since(loop);
            r.frames = std::size_t(frames);
            results.push_back(r);
        }
        {  // FramePipeline: copy in, mesh, hand over, three frames in flight
            Result r{"pipeline"};
            auto t0 = Clock::now();
            trilevel::Reconstructor rec(device);
            r.construct_ms = ms_since(t0);
            rec.reconstruct(frame(0).data(), frame(0).size() / 3, params);  // warm-up
            rec.reset_history();
            std::vector<trilevel::Stats> stats;
            std::size_t differ = 0;
            const auto loop = Clock::now();
            {
                trilevel::FramePipeline pipe(rec, params, [&](trilevel::PipelineFrame& f) {
                    if (f.error) std::rethrow_exception(f.error);
                    if (!same(f.mesh, host_meshes[f.index])) ++differ;
                    stats.push_back(f.stats);
                });
                for (int i = 0; i < frames; ++i) pipe.push(std::vector<float>(frame(i)));
                pipe.finish();
            }
            r.loop_ms = ms_since(loop);
            for (const auto& s : stats) r.add(s, stage(s, "total"));
            r.frames = std::size_t(frames);
            if (differ) {
                std::printf("pipeline: %zu meshes differ from the host loop's\n", differ);
                ok = false;
            }
            results.push_back(r);
        }
        for (const auto& r : results) print(r);
        if (!json_path.empty()) {
            std::ofstream out(json_path);
            out << "[";
            for (std::size_t i = 0; i < results.size(); ++i) out << (i ? ",\n " : "") << json(results[i]);
            out << "]\n";
        }
        std::printf(ok ? "meshes: device path and pipeline bit-identical to the host loop, all closed\n"
                       : "MESH MISMATCH or open mesh\n");
        return ok ? 0 : 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "device_frames: %s\n", e.what());
        return 1;
    }
}
