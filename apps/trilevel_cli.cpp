// trilevel: command-line front end. Subcommands: reconstruct, generate, info, devices.
// Every failure is one line "trilevel: error: <message>" on stderr; exit 1 (2 for usage errors).
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <future>
#include <iostream>
#include <limits>
#include <new>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#if defined(__linux__)
#include <sched.h>
#endif
#include <unistd.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include "environment.hpp"
#include "frame_sequence.hpp"
#include "io/io_common.hpp"
#include "trilevel/io.hpp"
#include "trilevel/params_table.hpp"
#include "trilevel/pipeline.hpp"
#include "trilevel/trilevel.hpp"

namespace {

using trilevel::cli::UsageError;  // bad option values (exit code 2)

/// Parses a number option given as text, so that "nan", "1e999" and "abc" get our own message.
double parse_number(const std::string& name, const std::string& text) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    // strtod also reads hexadecimal ("0x10" as 16) and skips leading blanks: decimal text only
    const bool decimal = text.find_first_of("xX \t\n") == std::string::npos;
    if (text.empty() || !decimal || end != text.c_str() + text.size())
        throw UsageError(name + " must be a number, got '" + text + "'");
    return v;
}

/// A length parameter: finite and > 0.
float positive(const std::string& name, const std::string& text) {
    const double v = parse_number(name, text);
    if (!std::isfinite(v)) throw UsageError(name + " must be finite, got '" + text + "'");
    if (v <= 0) throw UsageError(name + " must be > 0, got '" + text + "'");
    if (v > std::numeric_limits<float>::max() || static_cast<float>(v) <= 0.0f)
        throw UsageError(name + " is out of the float range, got '" + text + "'");
    return static_cast<float>(v);
}

/// Bytes, optionally with a K, M, G or T suffix (powers of 1024), e.g. "2G".
std::uint64_t parse_bytes(const std::string& text) {
    std::string digits = text;
    double scale = 1;
    if (!digits.empty() && std::isalpha(static_cast<unsigned char>(digits.back()))) {
        const char s = static_cast<char>(std::toupper(static_cast<unsigned char>(digits.back())));
        const std::string units = "KMGT";
        const auto u = units.find(s);
        if (u == std::string::npos) throw UsageError("--memory-limit: unknown unit in '" + text + "', expected K, M, G or T");
        scale = std::pow(1024.0, static_cast<double>(u + 1));
        digits.pop_back();
    }
    const double v = parse_number("--memory-limit", digits) * scale;
    if (!std::isfinite(v) || v < 1 || v > 1.8e19) throw UsageError("--memory-limit must be a positive byte count, got '" + text + "'");
    return static_cast<std::uint64_t>(v);
}

/// Fails early (before long work) when an output cannot be written: bad extension, no directory.
void check_output(const std::string& path, const std::vector<std::string>& extensions, const char* what) {
    const std::string ext = trilevel::io::extension_of(path);
    if (std::find(extensions.begin(), extensions.end(), ext) == extensions.end()) {
        std::string list;
        for (const auto& e : extensions) list += (list.empty() ? "." : ", .") + e;
        throw UsageError(path + ": unknown " + what + " extension '" + ext + "', expected " + list);
    }
    const auto dir = std::filesystem::path(path).parent_path();
    std::error_code ec;
    if (!dir.empty() && !std::filesystem::is_directory(dir, ec))
        throw trilevel::Error(path + ": output directory '" + dir.string() + "' does not exist");
    if (std::filesystem::is_directory(path, ec)) throw trilevel::Error(path + ": output path is a directory");
}

// ---------------------------------------------------------------------------------------------
// reconstruct

/// The default of a Params field as option text (trilevel/params_table.hpp), parsed like a user's.
std::string default_text(const char* field) {
    return trilevel::param_value_text(trilevel::param_info(field).read(trilevel::Params{}));
}

/// The --help line of a Params field: the table's help, a CLI note (option syntax), the default.
std::string help(const char* field, const std::string& note = "") {
    const std::string d = trilevel::param_cli_default_text(trilevel::param_info(field));
    return trilevel::param_info(field).help + (note.empty() ? "" : " " + note) + (d.empty() ? "" : " (default: " + d + ")");
}

/// The CLI names of a Params field's option.
std::string flag(const char* field) { return trilevel::param_info(field).cli; }

// Empty strings: the option was not given (Params{}'s value stays); the others start at Params{}'s.
struct ReconstructArgs {
    std::string input, output, radius, kernel_radius = default_text("kernel_radius"), mode = default_text("mode"),
        cell = default_text("cell"), threshold, memory, stats, hysteresis, level2_tolerance, threads,
        crack_closing = default_text("crack_closing"), smooth_iterations;
    std::string particle_box, clip_box, remove_below;  // input filter and post-processing
    bool has_particle_box = false, has_clip_box = false, has_remove_below = false;  // given (even empty)
    std::string start, end;  // frame sequences: range of frame numbers
    int device = -1;
    bool color_levels = false, quiet = false, skip_existing = false, drop_invalid = false;
    bool smooth = false, sliver_cleanup = false;
    std::string normals;                  ///< "" (none), "gradient" or "area"
    std::vector<std::string> attributes;  ///< particle attributes to interpolate at the vertices
};

/// A box option "X0,Y0,Z0,X1,Y1,Z1": six finite numbers, the minimum corner below the maximum.
trilevel::Box parse_box(const std::string& name, const std::string& text) {
    std::vector<double> v;
    std::size_t start = 0;
    bool numbers = true;
    while (numbers) {
        const std::size_t comma = text.find(',', start);
        const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
        char* end = nullptr;
        const double x = std::strtod(item.c_str(), &end);
        numbers = !item.empty() && end == item.c_str() + item.size() && std::isfinite(x) &&
                  std::fabs(x) <= std::numeric_limits<float>::max();
        v.push_back(x);
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    if (!numbers || v.size() != 6)
        throw UsageError(name + " must be six finite numbers X0,Y0,Z0,X1,Y1,Z1, got '" + text + "'");
    trilevel::Box b;
    for (int k = 0; k < 3; ++k) {
        b.min[k] = static_cast<float>(v[std::size_t(k)]);
        b.max[k] = static_cast<float>(v[std::size_t(k) + 3]);
        if (!(b.min[k] < b.max[k]))
            throw UsageError(name + " is empty: " + "XYZ"[k] + "0 must be below " + "XYZ"[k] + "1, got '" + text + "'");
    }
    return b;
}

trilevel::Params make_params(const ReconstructArgs& a) {
    trilevel::Params p;
    p.particle_radius = positive("radius (-r)", a.radius);
    p.kernel_radius = positive("kernel radius (--kernel-radius)", a.kernel_radius);
    if (p.kernel_radius < float(trilevel::kMinKernelRadius) || p.kernel_radius > float(trilevel::kMaxKernelRadius))
        throw UsageError("kernel radius (--kernel-radius) must lie in [" + std::to_string(trilevel::kMinKernelRadius) + ", " +
                         std::to_string(trilevel::kMaxKernelRadius) + "] particle radii, got '" + a.kernel_radius + "'");
    if (a.mode == "adaptive") p.mode = trilevel::Mode::Adaptive;
    else if (a.mode == "uniform") p.mode = trilevel::Mode::Uniform;
    else throw UsageError("--mode must be adaptive or uniform, got '" + a.mode + "'");
    if (a.device < -1)  // -1: not given (the first GPU, else the first CPU device)
        throw UsageError("--device must be a device index (0, 1, ...; see 'trilevel devices'), got " + std::to_string(a.device));
    p.cell = positive("cell (--cell)", a.cell);
    if (!trilevel::is_uniform_cell(p.cell)) throw UsageError("cell (--cell) " + a.cell + " " + trilevel::kUniformCellRule);
    if (!a.threshold.empty()) p.curvature_threshold = positive("curvature threshold (--curvature-threshold)", a.threshold);
    if (!a.level2_tolerance.empty()) {
        const double t = parse_number("--level2-tolerance", a.level2_tolerance);
        if (!(t >= 0 && t < 1e6))
            throw UsageError("--level2-tolerance must be >= 0 and below 1e6 (in r; 0 = off), got '" + a.level2_tolerance + "'");
        p.level2_tolerance = static_cast<float>(t);
    }
    if (a.crack_closing == "collapse") p.crack_closing = trilevel::CrackClosing::Collapse;
    else if (a.crack_closing == "patches") p.crack_closing = trilevel::CrackClosing::Patches;
    else throw UsageError("--crack-closing must be collapse or patches, got '" + a.crack_closing + "'");
    if (!a.memory.empty()) p.memory_limit_bytes = parse_bytes(a.memory);
    {  // the CLI's own default, for sequences (docs/calibration.md, "Temporal coherence"); no effect on one file
        const std::string& text = a.hysteresis.empty() ? trilevel::param_info("level_hysteresis").cli_default : a.hysteresis;
        const double h = parse_number("--level-hysteresis", text);
        if (!(h >= 0 && h < 1)) throw UsageError("--level-hysteresis must lie in [0, 1), got '" + text + "'");
        p.level_hysteresis = static_cast<float>(h);
    }
    if (a.has_particle_box) p.particle_box = parse_box("--particle-box", a.particle_box);
    if (a.has_clip_box) p.clip_box = parse_box("--clip-box", a.clip_box);
    if (a.has_remove_below) {
        const double n = parse_number("--remove-components-below", a.remove_below);
        if (!(n >= 0 && n <= 1e30))
            throw UsageError("--remove-components-below must be finite and >= 0 (particle volumes), got '" + a.remove_below + "'");
        p.remove_components_below = static_cast<float>(n);
    }
    if (a.normals == "gradient") p.normals = trilevel::NormalMode::Gradient;
    else if (a.normals == "area") p.normals = trilevel::NormalMode::Area;
    else if (!a.normals.empty()) throw UsageError("--normals must be gradient or area (or given alone), got '" + a.normals + "'");
    p.smooth = a.smooth || !a.smooth_iterations.empty();
    p.sliver_cleanup = a.sliver_cleanup;
    if (!a.smooth_iterations.empty()) {
        const bool digits = std::all_of(a.smooth_iterations.begin(), a.smooth_iterations.end(), [](char c) { return c >= '0' && c <= '9'; });
        const int n = digits && a.smooth_iterations.size() <= 4 ? std::stoi(a.smooth_iterations) : 0;
        if (n < 1 || n > trilevel::kMaxSmoothIterations)
            throw UsageError("--smooth-iterations must be a whole number from 1 to " + std::to_string(trilevel::kMaxSmoothIterations) +
                             ", got '" + a.smooth_iterations + "'");
        p.smooth_iterations = n;
    }
    return p;
}

/// --threads N: at most N CPU threads, for the host stages (TBB; the returned limit holds while it
/// lives) and for PoCL's CPU device (POCL_MAX_PTHREAD_COUNT, which PoCL reads when it starts: this
/// runs before any OpenCL call). GPU drivers keep their own threads. Empty: every core.
std::optional<int> thread_count(const std::string& text) {
    if (text.empty()) return std::nullopt;
    const bool digits = std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
    const int n = digits && text.size() <= 4 ? std::stoi(text) : 0;
    if (n < 1) throw UsageError("--threads must be a whole number from 1 to 9999, got '" + text + "'");
    return n;
}

std::optional<tbb::global_control> limit_threads(std::optional<int> n) {
    if (!n) return std::nullopt;
    ::setenv("POCL_MAX_PTHREAD_COUNT", std::to_string(*n).c_str(), 1);
    return std::optional<tbb::global_control>(std::in_place, tbb::global_control::max_allowed_parallelism, std::size_t(*n));
}

/// PoCL's CPU-device threads pinned one to a CPU (POCL_AFFINITY=1 pins its thread i to CPU i) when
/// this process may run on CPUs 0 to m-1 and nothing else, and PoCL runs m threads (no --threads,
/// or --threads m). Unpinned, the scheduler now and then stacks both kernel threads on one core
/// beside the reader, writer and host threads, and the other core idles: 50 x8 frames on 2 cores
/// took 0.95x the wall time pinned (bench/RESULTS-sequences.md). Not otherwise: PoCL pins by
/// thread index, so under any other CPU set (taskset, a container's cpuset, several jobs with
/// smaller --threads on one machine) it would move threads onto CPUs the process was not given,
/// or stack the jobs on the first CPUs. A POCL_AFFINITY the user set stays as it is, and so does
/// a POCL_MAX_PTHREAD_COUNT (it counts as the thread count when --threads is not given).
void pin_device_threads(std::optional<int> threads) {
#if defined(__linux__)  // POCL_AFFINITY is Linux-only in PoCL too
    if (std::getenv("POCL_AFFINITY")) return;
    if (const char* v = std::getenv("POCL_MAX_PTHREAD_COUNT"); v && !threads) threads = std::atoi(v);
    cpu_set_t allowed;
    CPU_ZERO(&allowed);
    if (::sched_getaffinity(0, sizeof(allowed), &allowed) != 0) return;
    const int m = CPU_COUNT(&allowed);
    for (int cpu = 0; cpu < m; ++cpu)
        if (!CPU_ISSET(cpu, &allowed)) return;  // not the first m CPUs
    if (threads && *threads != m) return;
    ::setenv("POCL_MAX_PTHREAD_COUNT", std::to_string(m).c_str(), 1);  // thread indices 0 .. m-1: the CPUs given
    ::setenv("POCL_AFFINITY", "1", 1);
#else
    (void)threads;
#endif
}

/// A frame number option (--start, --end): a non-negative integer.
std::optional<std::uint64_t> frame_option(const std::string& name, const std::string& text) {
    if (text.empty()) return std::nullopt;
    if (!std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }) || text.size() > 18)
        throw UsageError(name + " must be a frame number (a non-negative integer), got '" + text + "'");
    return std::stoull(text);
}

double total_ms(const trilevel::Stats& s, double wall_ms) {
    for (const auto& [name, ms] : s.time_ms)
        if (name == "total") return ms;
    return wall_ms;
}

/// A cold start compiles the OpenCL kernels, seconds on PoCL: say so once, so that the wait is not
/// taken for a hang (later starts load them from the program cache).
void say_compiling(const trilevel::KernelCompileNotice& n) {
    static bool said = false;
    if (std::exchange(said, true)) return;
    if (n.cache_dir.empty())
        std::fprintf(stderr, "trilevel: compiling OpenCL kernels for %s (on every start: caching is off, see TRILEVEL_CACHE_DIR)\n",
                     n.device.c_str());
    else
        std::fprintf(stderr, "trilevel: compiling OpenCL kernels for %s (once; cached in %s)\n", n.device.c_str(),
                     n.cache_dir.c_str());
}

/// A frame's particles: one-line Error for a file that fails to read or holds none. Warns about
/// particles dropped for NaN/Inf coordinates (--drop-invalid).
trilevel::ParticleSet read_input(const ReconstructArgs& a, const std::string& input) {
    trilevel::ReadOptions read_options;
    read_options.attributes = a.attributes;
    read_options.drop_invalid = a.drop_invalid;
    // The reader returns the --attribute names in their order (an Error names a missing one).
    trilevel::ParticleSet particles = trilevel::read_particles(input, read_options);
    if (particles.dropped_invalid > 0)
        std::fprintf(stderr, "warning: %s: dropped %zu particles with NaN/Inf coordinates\n", input.c_str(), particles.dropped_invalid);
    if (particles.size() == 0) throw trilevel::Error(input + ": holds no particles");
    return particles;
}

/// Writes a frame's mesh (and stats) file. Prints the summary unless quiet or `result` is given,
/// which receives a one-line summary and the level changes instead (frame sequences). `wall_ms`:
/// the time the frame took when the stats hold no total.
void write_outputs(const trilevel::Params& params, const ReconstructArgs& a, const std::string& input, const std::string& output,
                   const std::string& stats_path, const trilevel::Mesh& mesh, const trilevel::Stats& stats, double wall_ms,
                   trilevel::cli::FrameResult* result) {
    trilevel::MeshWriteOptions options;
    options.color_levels = a.color_levels;
    trilevel::write_mesh(output, mesh, options);
    if (!stats_path.empty()) {
        trilevel::io::AtomicWriter out(stats_path);
        out.write(trilevel::stats_to_json(stats, params));
        out.write("\n");
        out.commit();
    }
    const std::size_t count = stats.particles;
    if (result) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "%zu particles, %zu triangles, %s, %.0f ms", count, mesh.triangle_count(),
                      stats.closed ? "closed" : "NOT closed", total_ms(stats, wall_ms));
        result->line = buf;
        if (stats.level_history)
            result->line += ", " + std::to_string(stats.level_flips) + " of " + std::to_string(stats.level_cells_compared) +
                            " cells changed level";
        result->level_flips = stats.level_flips;
        result->level_cells_compared = stats.level_cells_compared;
    } else if (!a.quiet)
        std::printf("particles: %zu\nsurface cells: %zu (level 2: %zu, level 3: %zu)\ntriangles: %zu\nclosed: %s\n"
                    "total time: %.1f ms\noutput: %s\n",
                    count, stats.surface_cells, stats.surface_cells_level2, stats.surface_cells_level3,
                    mesh.triangle_count(), stats.closed ? "yes" : "no", total_ms(stats, wall_ms), output.c_str());
    if (!a.quiet && !result) {
        if (params.particle_box) std::printf("particles outside --particle-box: %zu\n", stats.particles_outside_box);
        if (params.remove_components_below > 0) std::printf("components removed: %zu\n", stats.components_removed);
        if (params.clip_box) std::printf("clip-box cap triangles: %zu\n", stats.clip_cap_triangles);
    }
    if (params.clip_box && mesh.triangle_count() == 0)
        std::fprintf(stderr, "warning: %s: --clip-box holds no part of the surface, the mesh is empty\n", input.c_str());
}

/// Reads `input` on another thread while `rec`, when empty, is created on this one: OpenCL starts
/// (device, cached kernels) while the file is read, and a bad file is still the error reported when
/// both fail. (The reverse, OpenCL on the second thread, made ASan's teardown of that thread fail.)
trilevel::ParticleSet read_while_starting(std::optional<trilevel::Reconstructor>& rec, const ReconstructArgs& a,
                                         const std::string& input) {
    auto reading = std::async(std::launch::async, [&] { return read_input(a, input); });
    std::exception_ptr start_failure;
    if (!rec) {  // compiled kernels and buffers are reused across frames
        try {
            rec.emplace(a.device, a.quiet ? nullptr : &say_compiling);  // -q: nothing on success
        } catch (...) {
            start_failure = std::current_exception();
        }
    }
    trilevel::ParticleSet particles = reading.get();  // a bad file first
    if (start_failure) std::rethrow_exception(start_failure);
    return particles;
}

/// One input file -> one mesh (and stats) file, one step after the other; `result` as in write_outputs.
void reconstruct_file(std::optional<trilevel::Reconstructor>& rec, const trilevel::Params& params, const ReconstructArgs& a,
                      const std::string& input, const std::string& output, const std::string& stats_path,
                      trilevel::cli::FrameResult* result = nullptr) {
    const auto start = std::chrono::steady_clock::now();
    trilevel::ParticleSet particles = read_while_starting(rec, a, input);
    trilevel::Stats stats;
    // The positions are handed over: the library frees them once they are on the device.
    const trilevel::Mesh mesh = rec->reconstruct(std::move(particles.positions), params, &stats, particles.attributes);
    const double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    write_outputs(params, a, input, output, stats_path, mesh, stats, wall, result);
}

/// Whether sequences are pipelined: TRILEVEL_PIPELINE=0 turns it off (one frame at a time, the
/// lowest memory; tests compare the two).
bool pipelining() { return trilevel::environment().pipeline; }

/// A frame sequence through a trilevel::FramePipeline: this thread reads frame k+1 while the
/// pipeline's worker meshes frame k and its sink writes frame k-1 and reports it, in frame order.
/// The meshes are those of one frame at a time (same Reconstructor, same order). Returns nullopt,
/// having done nothing, when the OpenCL device cannot be opened: the caller then runs one frame at
/// a time, which reports that error for every frame as before.
std::optional<int> run_pipelined_sequence(const trilevel::cli::SequencePlan& plan, const trilevel::cli::SequenceOptions& options,
                                          const trilevel::Params& params, const ReconstructArgs& a) {
    using trilevel::cli::FrameJob;
    const std::vector<FrameJob>& jobs = plan.jobs;
    std::optional<trilevel::Reconstructor> rec;
    std::optional<trilevel::ParticleSet> first;
    std::exception_ptr first_failure;
    try {
        first = read_while_starting(rec, a, jobs.front().input);
    } catch (...) {
        first_failure = std::current_exception();
    }
    if (!rec) return std::nullopt;

    trilevel::cli::SequenceReport report(plan, options);
    trilevel::FramePipeline pipeline(*rec, params, [&](trilevel::PipelineFrame& f) {
        const FrameJob& job = jobs[f.index];
        std::exception_ptr error = f.error;
        if (!error) {
            try {
                trilevel::cli::FrameResult result;
                write_outputs(params, a, job.input, job.output, job.stats, f.mesh, f.stats, 0.0, &result);
                report.ok(job, result);
            } catch (...) {
                error = std::current_exception();
            }
        }
        if (error) report.failed(job, trilevel::cli::failure_message(error));
        if (f.index + 1 < jobs.size()) report.started(jobs[f.index + 1]);
    });
    report.started(jobs.front());
    for (std::size_t i = 0; i < jobs.size(); ++i) {
        std::exception_ptr failure = i == 0 ? first_failure : nullptr;
        trilevel::ParticleSet particles;
        if (i == 0 && first) particles = std::move(*first);
        else if (i > 0) {
            try {
                particles = read_input(a, jobs[i].input);
            } catch (...) {
                failure = std::current_exception();
            }
        }
        if (failure) pipeline.push_failed(failure);
        else pipeline.push(std::move(particles.positions), std::move(particles.attributes));
    }
    pipeline.finish();
    return report.finish();
}

int run_reconstruct(const ReconstructArgs& a) {
    const trilevel::Params params = make_params(a);
    const std::optional<int> threads = thread_count(a.threads);
    const auto thread_limit = limit_threads(threads);
    pin_device_threads(threads);
    const bool sequence = trilevel::cli::is_sequence_pattern(a.input);
    if (sequence && !trilevel::cli::is_sequence_pattern(a.output))
        throw UsageError("-o must contain '{}' when the input is a frame sequence");
    if (sequence && !a.stats.empty() && !trilevel::cli::is_sequence_pattern(a.stats))
        throw UsageError("--stats must contain '{}' when the input is a frame sequence");
    if (!sequence && (!a.start.empty() || !a.end.empty() || a.skip_existing))
        throw UsageError("--start, --end and --skip-existing need a frame sequence ('{}' in the input)");
    check_output(trilevel::cli::frame_path(a.output, "0"), {"ply", "obj", "vtk", "vtp", "vtu"}, "mesh");
    if (!a.stats.empty()) check_output(trilevel::cli::frame_path(a.stats, "0"), {"json"}, "statistics");
    if (!sequence) {
        trilevel::cli::require_distinct_outputs(a.input, a.output, a.stats, "");
        std::optional<trilevel::Reconstructor> rec;
        reconstruct_file(rec, params, a, a.input, a.output, a.stats);
        return 0;
    }
    trilevel::cli::SequenceOptions options;
    options.start = frame_option("--start", a.start);
    options.end = frame_option("--end", a.end);
    options.skip_existing = a.skip_existing;
    options.quiet = a.quiet;
    options.progress_bar = ::isatty(STDERR_FILENO) != 0;
    const auto plan = trilevel::cli::plan_frame_sequence(a.input, a.output, a.stats, options);
    if (pipelining() && !plan.jobs.empty())
        if (const std::optional<int> status = run_pipelined_sequence(plan, options, params, a)) return *status;
    std::optional<trilevel::Reconstructor> rec;  // one for the whole run, from its first frame: no level
                                                 // history before that frame
    return trilevel::cli::run_frame_sequence(plan, options, [&](const trilevel::cli::FrameJob& job) {
        trilevel::cli::FrameResult result;
        reconstruct_file(rec, params, a, job.input, job.output, job.stats, &result);
        return result;
    });
}

// ---------------------------------------------------------------------------------------------
// generate

struct GenerateArgs {
    std::string scene, output, radius;
    std::uint64_t seed = 1;
    int frame = 0, frames = 1;  // moving scenes: the first frame and how many
};

int run_generate(const GenerateArgs& a) {
    const float radius = positive("radius (--radius)", a.radius);
    const auto names = trilevel::scene_names();
    if (std::find(names.begin(), names.end(), a.scene) == names.end()) {
        std::string list;
        for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
        throw UsageError("unknown scene '" + a.scene + "', expected one of: " + list);
    }
    if (a.frame < 0) throw UsageError("--frame must be >= 0, got " + std::to_string(a.frame));
    if (a.frames < 1) throw UsageError("--frames must be >= 1, got " + std::to_string(a.frames));
    const bool sequence = trilevel::cli::is_sequence_pattern(a.output);
    if (a.frames > 1 && !sequence) throw UsageError("-o must contain '{}' when --frames is more than 1");
    check_output(trilevel::cli::frame_path(a.output, "0"), {"xyz", "ply", "vtk"}, "particle");
    for (int f = a.frame; f < a.frame + a.frames; ++f) {
        const std::string path = trilevel::cli::frame_path(a.output, trilevel::cli::padded_frame(std::uint64_t(f), 4));
        const auto set = trilevel::generate_scene(a.scene, radius, a.seed, f);
        trilevel::write_particles(path, set);
        std::printf("%zu particles -> %s\n", set.size(), path.c_str());
    }
    return 0;
}

// ---------------------------------------------------------------------------------------------
// info

/// Particles bucketed by a hash of their cell of width h, as compressed rows: bucket b holds
/// index[start[b] .. start[b + 1]). Cells that share a bucket share its row, which only adds
/// candidates to a search. Two passes over flat arrays, not a map of one vector per cell (most of
/// `info`'s time on large files).
struct HashGrid {
    double h = 0;
    std::uint64_t mask = 0;
    std::vector<std::uint32_t> start, index;

    std::int64_t cell(const std::vector<float>& p, const float lo[3], std::size_t i, int k) const {
        return static_cast<std::int64_t>((p[3 * i + k] - lo[k]) / h);
    }
    std::uint64_t bucket(std::int64_t x, std::int64_t y, std::int64_t z) const {
        std::uint64_t v = (static_cast<std::uint64_t>(x) * 73856093u) ^ (static_cast<std::uint64_t>(y) * 19349663u) ^
                          (static_cast<std::uint64_t>(z) * 83492791u);
        v ^= v >> 31;  // the low bits pick the bucket: mix the high ones in
        v *= 0x9e3779b97f4a7c15ull;
        return (v ^ (v >> 29)) & mask;
    }
};

/// Buckets the particles into cells of width h; returns the largest bucket size.
std::size_t fill_grid(const std::vector<float>& p, const float lo[3], double h, HashGrid& grid) {
    const std::size_t n = p.size() / 3;
    grid.h = h;
    std::size_t buckets = 1024;
    while (buckets < n) buckets *= 2;
    grid.mask = buckets - 1;
    std::vector<std::uint32_t> of(n);
    grid.start.assign(buckets + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
        of[i] = std::uint32_t(grid.bucket(grid.cell(p, lo, i, 0), grid.cell(p, lo, i, 1), grid.cell(p, lo, i, 2)));
        ++grid.start[of[i] + 1];
    }
    std::size_t largest = 0;
    for (std::size_t b = 0; b < buckets; ++b) {
        largest = std::max<std::size_t>(largest, grid.start[b + 1]);
        grid.start[b + 1] += grid.start[b];
    }
    grid.index.resize(n);
    std::vector<std::uint32_t> fill(grid.start.begin(), grid.start.end() - 1);
    for (std::size_t i = 0; i < n; ++i) grid.index[fill[of[i]]++] = std::uint32_t(i);
    return largest;
}

/// Distance from particle i to its nearest other particle, searching up to 64 rings of cells.
double nearest(const std::vector<float>& p, const float lo[3], const HashGrid& grid, std::size_t i) {
    std::int64_t c[3];
    for (int k = 0; k < 3; ++k) c[k] = grid.cell(p, lo, i, k);
    double best = std::numeric_limits<double>::infinity();
    // a point first seen in ring r lies at least (r - 1) h away: stop once best is closer than that
    // (points of other cells in the same bucket are real points too, so best stays a true distance)
    for (std::int64_t r = 0; r <= 64 && best > (r - 1) * grid.h; ++r)
        for (std::int64_t dx = -r; dx <= r; ++dx)
            for (std::int64_t dy = -r; dy <= r; ++dy)
                for (std::int64_t dz = -r; dz <= r; ++dz) {
                    if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != r) continue;
                    const std::uint64_t b = grid.bucket(c[0] + dx, c[1] + dy, c[2] + dz);
                    for (std::uint32_t s = grid.start[b]; s < grid.start[b + 1]; ++s) {
                        const std::uint32_t j = grid.index[s];
                        if (j == i) continue;
                        double d2 = 0;
                        for (int k = 0; k < 3; ++k) d2 += (double(p[3 * j + k]) - p[3 * i + k]) * (double(p[3 * j + k]) - p[3 * i + k]);
                        best = std::min(best, std::sqrt(d2));
                    }
                }
    return best;
}

/// Median nearest-neighbour distance over up to 2000 particles, using a hash grid whose cells
/// start at about one particle each and shrink while some cell is crowded.
double estimate_spacing(const std::vector<float>& p, const float lo[3], const float hi[3]) {
    const std::size_t n = p.size() / 3;
    if (n < 2) return 0;
    double extent = 0, volume = 1;
    for (int k = 0; k < 3; ++k) extent = std::max(extent, double(hi[k]) - lo[k]);
    if (extent <= 0) return 0;
    for (int k = 0; k < 3; ++k) volume *= std::max(double(hi[k]) - lo[k], 1e-3 * extent);  // flat sets stay 3D
    double h = std::cbrt(volume / double(n));
    HashGrid grid;
    for (int halvings = 0; fill_grid(p, lo, h, grid) > 64 && halvings < 10; ++halvings) h *= 0.5;
    const std::size_t samples = std::min<std::size_t>(n, 2000), stride = n / samples;
    std::vector<double> found;
    for (std::size_t s = 0; s < samples; ++s) {
        const double d = nearest(p, lo, grid, s * stride);
        if (std::isfinite(d)) found.push_back(d);
    }
    if (found.empty()) return 0;
    std::nth_element(found.begin(), found.begin() + found.size() / 2, found.end());
    return found[found.size() / 2];
}

int run_info(const std::string& input) {
    const auto set = trilevel::read_particles(input);  // rejects NaN/Inf, so what it returns is finite
    float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (std::size_t i = 0; i < set.size(); ++i)
        for (int k = 0; k < 3; ++k) {
            const float v = set.positions[3 * i + k];
            lo[k] = i == 0 ? v : std::min(lo[k], v);
            hi[k] = i == 0 ? v : std::max(hi[k], v);
        }
    const double spacing = estimate_spacing(set.positions, lo, hi);
    std::printf("file: %s\nparticles: %zu\nbounding box: [%g, %g, %g] - [%g, %g, %g]\nfinite: yes\n", input.c_str(),
                set.size(), lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    if (spacing > 0) std::printf("median nearest-neighbour spacing: %g (radius estimate %g)\n", spacing, spacing / 2);
    else std::printf("median nearest-neighbour spacing: n/a\n");
    return 0;
}

// ---------------------------------------------------------------------------------------------
// devices

int run_devices() {
    const auto devices = trilevel::list_devices();
    if (devices.empty()) {
        std::printf("no OpenCL devices\n");
        return 0;
    }
    for (const auto& d : devices)
        std::printf("%d: %s / %s\n   type %s, %u compute units, global memory %.1f MiB, max allocation %.1f MiB, "
                    "int64 atomics %s\n",
                    d.index, d.platform.c_str(), d.name.c_str(), d.type.c_str(), d.compute_units,
                    double(d.global_memory) / (1 << 20), double(d.max_allocation) / (1 << 20), d.int64_atomics ? "yes" : "no");
    return 0;
}

/// The error as one stderr line, whatever the message holds; returns the exit code.
int report(const std::string& message, int code) {
    std::fprintf(stderr, "trilevel: error: %s\n", trilevel::cli::one_line(message).c_str());
    return code;
}

int run(int argc, char** argv) {
    CLI::App app{"trilevel: adaptive surface reconstruction of SPH particle sets (OpenCL)", "trilevel"};
    app.require_subcommand(1);

    ReconstructArgs ra;
    auto* rec = app.add_subcommand("reconstruct", "Reconstructs a closed triangle mesh from a particle file");
    rec->add_option("input", ra.input, "Particle file (.vtk, .vtu, .bgeo, .ply, .xyz); '{}' in the name: frame sequence")->required();
    rec->add_option("-o,--output", ra.output, "Mesh file (.ply, .obj, .vtk, .vtp, .vtu); '{}' is replaced by the frame number")->required();
    rec->add_option(flag("particle_radius"), ra.radius, help("particle_radius"))->required();
    rec->add_option(flag("kernel_radius"), ra.kernel_radius, help("kernel_radius"));
    rec->add_option(flag("mode"), ra.mode, help("mode"));
    rec->add_option(flag("cell"), ra.cell, help("cell"));
    rec->add_option(flag("curvature_threshold"), ra.threshold, help("curvature_threshold"));
    rec->add_option(flag("level2_tolerance"), ra.level2_tolerance, help("level2_tolerance"));
    rec->add_option(flag("crack_closing"), ra.crack_closing, help("crack_closing"));
    rec->add_option("--device", ra.device, "OpenCL device index (see `trilevel devices`)");
    rec->add_option("--threads", ra.threads, "CPU threads for the host stages and PoCL (default: every core)");
    rec->add_option("--stats", ra.stats, "Write statistics as JSON");
    rec->add_flag("--color-levels", ra.color_levels, "PLY: colour vertices by level (green 2, blue 3)");
    auto* normals = rec->add_option(flag("normals"), ra.normals, help("normals", "(given alone: 'gradient')"))->expected(0, 1);
    rec->add_flag(flag("smooth"), ra.smooth, help("smooth"));
    rec->add_option(flag("smooth_iterations"), ra.smooth_iterations, help("smooth_iterations"));
    rec->add_flag(flag("sliver_cleanup"), ra.sliver_cleanup, help("sliver_cleanup"));
    rec->add_option("--attribute", ra.attributes,
                    "Particle attribute to interpolate at the vertices (e.g. velocity; .vtk/.vtu/.bgeo input; repeatable)")
        ->allow_extra_args(false);  // one name per --attribute, so a following input file stays positional
    rec->add_option(flag("memory_limit_bytes"), ra.memory, help("memory_limit_bytes", "(bytes, or e.g. 2G)"));
    rec->add_flag("-q,--quiet", ra.quiet, "Print nothing on success but warnings (dropped particles, an empty clip box)");
    rec->add_option(flag("level_hysteresis"), ra.hysteresis, help("level_hysteresis"));
    auto* particle_box = rec->add_option(flag("particle_box"), ra.particle_box, help("particle_box"));
    auto* remove_below = rec->add_option(flag("remove_components_below"), ra.remove_below, help("remove_components_below"));
    auto* clip_box = rec->add_option(flag("clip_box"), ra.clip_box, help("clip_box"));
    rec->add_option("--start", ra.start, "Sequences: first frame number to process (inclusive)");
    rec->add_option("--end", ra.end, "Sequences: last frame number to process (inclusive)");
    rec->add_flag("--skip-existing", ra.skip_existing, "Sequences: skip frames whose outputs exist (resume a run)");
    rec->add_flag("--drop-invalid", ra.drop_invalid, "Drop particles with NaN/Inf coordinates (with a warning) instead of failing");

    GenerateArgs ga;
    auto* gen = app.add_subcommand("generate", "Writes a test particle scene");
    gen->add_option("scene", ga.scene, "block, sphere, dam-break, pool-and-drop, falling-drop (moving), or the analytic bodies ball, torus, rounded-box")->required();
    gen->add_option("-o,--output", ga.output, "Particle file (.xyz, .ply, .vtk); '{}': frame number, 4 digits")->required();
    gen->add_option("--frame", ga.frame, "Moving scenes: the (first) frame to write (default 0)");
    gen->add_option("--frames", ga.frames, "How many consecutive frames to write (default 1; needs '{}' in -o)");
    gen->add_option("--radius", ga.radius, "Particle radius in world units")->required();
    gen->add_option("--seed", ga.seed, "Jitter seed (default 1)");

    std::string info_input;
    auto* info = app.add_subcommand("info", "Prints count, bounding box and spacing of a particle file");
    info->add_option("input", info_input, "Particle file")->required();

    auto* devices = app.add_subcommand("devices", "Lists OpenCL devices");

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        return report(e.what(), 2);
    }
    if (rec->parsed() && normals->count() > 0 && ra.normals.empty()) ra.normals = "gradient";
    ra.has_particle_box = particle_box->count() > 0;
    ra.has_clip_box = clip_box->count() > 0;
    ra.has_remove_below = remove_below->count() > 0;
    if (rec->parsed()) return run_reconstruct(ra);
    if (gen->parsed()) return run_generate(ga);
    if (info->parsed()) return run_info(info_input);
    if (devices->parsed()) return run_devices();
    return report("no subcommand given", 2);
}

}  // namespace

int main(int argc, char** argv) {
    trilevel::io::remove_temporaries_on_signals();  // Ctrl-C never leaves a temporary output behind
#if defined(__GLIBC__)
    // Blocks of 1 MiB or more get mappings of their own, returned to the system when freed: under
    // glibc's default the threshold grows with each large free, so the particle arrays freed
    // between stages stayed in the heap and counted towards the peak (bench/RESULTS-implementation.md).
    mallopt(M_MMAP_THRESHOLD, 1 << 20);
#endif
    try {
        return run(argc, argv);
    } catch (const UsageError& e) {
        return report(e.what(), 2);
    } catch (const std::bad_alloc&) {
        return report("out of memory", 1);
    } catch (const std::exception& e) {
        return report(e.what(), 1);
    } catch (...) {
        return report("unknown failure", 1);
    }
}
