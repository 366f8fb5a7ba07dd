// Frame sequences in the CLI (frame_sequence.hpp): discovery, range, resume, progress, summary.
#include "frame_sequence.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <new>

#include "trilevel/trilevel.hpp"

namespace trilevel::cli {

namespace {

/// The file `path` writes to: absolute, "." and ".." and symbolic links resolved (as far as they
/// exist; writes go through links, AtomicWriter). A hard link is another file for a write: the
/// rename replaces that name only. "" stays "".
std::filesystem::path written_file(const std::string& path) {
    if (path.empty()) return {};
    std::error_code ec;
    const std::filesystem::path p = std::filesystem::weakly_canonical(path, ec);
    return ec ? std::filesystem::path(path) : p;
}

}  // namespace

void require_distinct_outputs(const std::string& input, const std::string& output, const std::string& stats,
                              const std::string& what) {
    const std::string frame = what.empty() ? "" : what + ": ";
    const auto in = written_file(input), mesh = written_file(output), st = written_file(stats);
    if (mesh == in) throw UsageError(frame + "the mesh " + output + " would overwrite the input");
    if (!st.empty() && st == in) throw UsageError(frame + "the statistics " + stats + " would overwrite the input");
    if (!st.empty() && st == mesh) throw UsageError(frame + "the statistics " + stats + " would overwrite the mesh");
}

bool is_sequence_pattern(const std::string& pattern) { return pattern.find("{}") != std::string::npos; }

std::string frame_path(const std::string& pattern, const std::string& number) {
    std::string path;
    std::size_t from = 0;
    for (auto at = pattern.find("{}"); at != std::string::npos; from = at + 2, at = pattern.find("{}", from))
        path += pattern.substr(from, at - from) + number;
    return path + pattern.substr(from);
}

std::string padded_frame(std::uint64_t frame, int width) {
    std::string s = std::to_string(frame);
    return s.size() < std::size_t(width) ? std::string(std::size_t(width) - s.size(), '0') + s : s;
}

namespace {

/// The value of a frame number; numbers beyond 64 bits saturate (they still sort after the rest).
std::uint64_t frame_value(const std::string& digits) {
    std::uint64_t v = 0;
    for (char c : digits) {
        const std::uint64_t d = std::uint64_t(c - '0');
        if (v > (UINT64_MAX - d) / 10) return UINT64_MAX;
        v = v * 10 + d;
    }
    return v;
}

bool all_digits(const std::string& s) {
    return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

}  // namespace

std::string one_line(std::string s) {
    std::replace(s.begin(), s.end(), '\n', ' ');
    std::replace(s.begin(), s.end(), '\r', ' ');
    return s;
}

std::vector<Frame> find_frames(const std::string& pattern) {
    const std::filesystem::path p(pattern);
    const std::string name = p.filename().string();
    const auto at = name.find("{}");
    if (at == std::string::npos) throw UsageError(pattern + ": '{}' must be in the file name, not in a directory");
    const std::string prefix = name.substr(0, at), suffix = name.substr(at + 2);
    const auto dir = p.parent_path().empty() ? std::filesystem::path(".") : p.parent_path();
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) throw Error(pattern + ": directory '" + dir.string() + "' does not exist");
    std::vector<Frame> frames;
    for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
        const std::string f = e.path().filename().string();
        if (f.size() <= prefix.size() + suffix.size() || f.compare(0, prefix.size(), prefix) != 0 ||
            f.compare(f.size() - suffix.size(), suffix.size(), suffix) != 0)
            continue;
        const std::string mid = f.substr(prefix.size(), f.size() - prefix.size() - suffix.size());
        if (all_digits(mid)) frames.push_back({mid, frame_value(mid)});
    }
    if (ec) throw Error(pattern + ": cannot list directory '" + dir.string() + "': " + ec.message());
    std::sort(frames.begin(), frames.end(), [](const Frame& x, const Frame& y) {
        return x.value != y.value ? x.value < y.value : x.number < y.number;
    });
    if (frames.empty()) throw Error(pattern + ": no frame files match");
    return frames;
}

namespace {

using Clock = std::chrono::steady_clock;

/// "1:05" or "2:03:07".
std::string clock_time(double seconds) {
    const long s = long(seconds + 0.5);
    char buf[32];
    if (s >= 3600) std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
    else std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
    return buf;
}

/// Progress over the frames to process: a bar redrawn in place on stderr (a terminal), or one line
/// per frame on stdout. Failures are one stderr line each in both cases.
class Progress {
public:
    Progress(std::size_t total, const SequenceOptions& o) : total_(total), options_(o), start_(Clock::now()) {}

    /// The bar shows the frame being worked on (frames can take seconds each).
    void frame_started(const FrameJob& job) {
        if (options_.progress_bar && !options_.quiet) draw(job);
    }

    void frame_ok(const FrameJob& job, const std::string& line) {
        ++done_;
        if (options_.quiet) return;
        if (options_.progress_bar) return draw(job);
        std::printf("frame %s [%zu/%zu]: %s; %s\n", job.frame.number.c_str(), done_, total_, line.c_str(), rate_eta().c_str());
        std::fflush(stdout);
    }

    void frame_failed(const FrameJob& job, const std::string& message) {
        ++done_;
        clear_bar();
        std::fprintf(stderr, "trilevel: error: frame %s: %s\n", job.frame.number.c_str(), one_line(message).c_str());
        std::fflush(stderr);
    }

    void finish() { clear_bar(); }
    double elapsed() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

private:
    std::string rate_eta() const {
        const double t = elapsed();
        if (done_ == 0 || t <= 0) return "ETA ?";
        const double rate = double(done_) / t;
        char buf[96];
        std::snprintf(buf, sizeof buf, "%.2f frames/s, ETA %s", rate, clock_time(double(total_ - done_) / rate).c_str());
        return buf;
    }

    void draw(const FrameJob& job) {
        constexpr int kWidth = 24;
        const int filled = total_ ? int(kWidth * done_ / total_) : kWidth;
        std::fprintf(stderr, "\r[%s%s] %zu/%zu frames, %s (frame %s)\033[K", std::string(std::size_t(filled), '#').c_str(),
                     std::string(std::size_t(kWidth - filled), '-').c_str(), done_, total_, rate_eta().c_str(),
                     job.frame.number.c_str());
        std::fflush(stderr);
        drawn_ = true;
    }

    void clear_bar() {
        if (!drawn_) return;
        std::fprintf(stderr, "\r\033[K");
        drawn_ = false;
    }

    std::size_t total_, done_ = 0;
    SequenceOptions options_;
    Clock::time_point start_;
    bool drawn_ = false;
};

/// The jobs of the frames in [start, end].
std::vector<FrameJob> select_jobs(const std::string& input, const std::string& output, const std::string& stats,
                                  const SequenceOptions& o) {
    const std::vector<Frame> frames = find_frames(input);
    std::vector<FrameJob> jobs;
    for (const Frame& f : frames)
        if ((!o.start || f.value >= *o.start) && (!o.end || f.value <= *o.end))
            jobs.push_back({f, frame_path(input, f.number), frame_path(output, f.number), frame_path(stats, f.number)});
    if (jobs.empty())
        throw Error(input + ": no frame in [" + (o.start ? std::to_string(*o.start) : std::string("first")) + ", " +
                    (o.end ? std::to_string(*o.end) : std::string("last")) + "]; the files hold frames " +
                    frames.front().number + " to " + frames.back().number);
    return jobs;
}

bool outputs_exist(const FrameJob& job) {
    std::error_code ec;
    return std::filesystem::exists(job.output, ec) && (job.stats.empty() || std::filesystem::exists(job.stats, ec));
}

}  // namespace

SequencePlan plan_frame_sequence(const std::string& input, const std::string& output, const std::string& stats,
                                 const SequenceOptions& options) {
    if (options.start && options.end && *options.start > *options.end)
        throw UsageError("--start " + std::to_string(*options.start) + " is after --end " + std::to_string(*options.end));
    SequencePlan plan;
    plan.jobs = select_jobs(input, output, stats, options);
    for (const FrameJob& job : plan.jobs) require_distinct_outputs(job.input, job.output, job.stats, "frame " + job.frame.number);
    plan.selected = plan.jobs.size();
    if (options.skip_existing)
        plan.jobs.erase(std::remove_if(plan.jobs.begin(), plan.jobs.end(), outputs_exist), plan.jobs.end());
    plan.skipped = plan.selected - plan.jobs.size();
    return plan;
}

std::string failure_message(std::exception_ptr error) {
    try {
        std::rethrow_exception(error);
    } catch (const std::bad_alloc&) {
        return "out of memory";
    } catch (const std::exception& e) {
        return one_line(e.what());
    } catch (...) {
        return "unknown failure";
    }
}

struct SequenceReport::Impl {
    Impl(const SequencePlan& plan, const SequenceOptions& o) : plan(plan), options(o), progress(plan.jobs.size(), o) {}
    const SequencePlan& plan;
    SequenceOptions options;
    Progress progress;
    std::vector<std::pair<std::string, std::string>> failures;  // frame number, message
    std::size_t flips = 0, compared = 0;
};

SequenceReport::SequenceReport(const SequencePlan& plan, const SequenceOptions& options)
    : impl_(std::make_unique<Impl>(plan, options)) {}
SequenceReport::~SequenceReport() = default;

void SequenceReport::started(const FrameJob& job) { impl_->progress.frame_started(job); }

void SequenceReport::ok(const FrameJob& job, const FrameResult& r) {
    impl_->flips += r.level_flips;
    impl_->compared += r.level_cells_compared;
    impl_->progress.frame_ok(job, r.line);
}

void SequenceReport::failed(const FrameJob& job, const std::string& message) {
    impl_->failures.emplace_back(job.frame.number, one_line(message));
    impl_->progress.frame_failed(job, impl_->failures.back().second);
}

int SequenceReport::finish() {
    Impl& s = *impl_;
    s.progress.finish();
    const std::size_t selected = s.plan.selected, skipped = s.plan.skipped;
    const auto& failures = s.failures;
    const std::size_t ok = s.plan.jobs.size() - failures.size();
    if (!s.options.quiet || !failures.empty()) {
        std::string failed = std::to_string(failures.size()) + " failed";
        for (std::size_t i = 0; i < failures.size() && i < 3; ++i)
            failed += (i == 0 ? " (frame " : ", frame ") + failures[i].first + ": " + failures[i].second;
        if (failures.size() > 3) failed += ", and " + std::to_string(failures.size() - 3) + " more";
        if (!failures.empty()) failed += ")";
        const double t = s.progress.elapsed();
        std::printf("%zu frames: %zu ok, %s, %zu skipped; %.1f s, %.2f frames/s\n", selected, ok, failed.c_str(), skipped,
                    t, t > 0 ? double(s.plan.jobs.size()) / t : 0.0);
        if (s.compared > 0)
            std::printf("level changes between consecutive frames: %zu of %zu coarse cells (%.4f%%)\n", s.flips, s.compared,
                        100.0 * double(s.flips) / double(s.compared));
        std::fflush(stdout);
    }
    if (failures.empty()) return 0;
    std::fprintf(stderr, "trilevel: error: %zu of %zu frames failed\n", failures.size(), selected);
    return 1;
}

int run_frame_sequence(const SequencePlan& plan, const SequenceOptions& options,
                       const std::function<FrameResult(const FrameJob&)>& work) {
    SequenceReport report(plan, options);
    for (const FrameJob& job : plan.jobs) {
        report.started(job);
        std::exception_ptr error;
        try {
            report.ok(job, work(job));
            continue;
        } catch (...) {
            error = std::current_exception();
        }
        report.failed(job, failure_message(error));
    }
    return report.finish();
}

}  // namespace trilevel::cli
