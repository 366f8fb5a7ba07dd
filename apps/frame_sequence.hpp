// Frame sequences in the CLI: "{}" in a file name stands for a frame number with any zero padding
// ("fluid_{}.bgeo" matches fluid_7.bgeo and fluid_0007.bgeo). The frames found are processed in
// numeric order, optionally restricted to [start, end] (how a render farm splits a sequence: one
// task per range), resumably (frames whose outputs exist are skipped), and a frame that fails is
// reported while the run goes on.
#pragma once

#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel::cli {

/// A usage error: bad option values or patterns (the CLI exits with 2 instead of 1).
struct UsageError : Error {
    using Error::Error;
};

/// `s` with its line breaks turned into spaces: every error is one line on stderr.
std::string one_line(std::string s);

/// UsageError when a frame's mesh or statistics would overwrite its input (or the statistics the
/// mesh): `what` names the frame in the message ("" for a single file).
void require_distinct_outputs(const std::string& input, const std::string& output, const std::string& stats,
                              const std::string& what);

/// Whether `pattern` names a frame sequence (holds "{}").
bool is_sequence_pattern(const std::string& pattern);

/// `pattern` with every "{}" replaced by `number` (as written, padding kept); unchanged without "{}".
std::string frame_path(const std::string& pattern, const std::string& number);

/// `frame` written with at least `width` digits, zero-padded.
std::string padded_frame(std::uint64_t frame, int width);

/// One frame of a sequence: its number as written in the file name and its value.
struct Frame {
    std::string number;
    std::uint64_t value = 0;
};

/// The frames whose files match `pattern` ("{}" in the file name, not in a directory), in numeric
/// order (equal values: by their text). Throws trilevel::Error when the directory is missing or
/// nothing matches.
std::vector<Frame> find_frames(const std::string& pattern);

/// A frame's paths: the input file and its outputs (an empty pattern gives an empty path).
struct FrameJob {
    Frame frame;
    std::string input, output, stats;
};

/// What processing a frame gave: a one-line description ("30356 particles, 45210 triangles,
/// 85 ms") and its level changes against the previous frame (Stats::level_flips).
struct FrameResult {
    std::string line;
    std::size_t level_flips = 0, level_cells_compared = 0;
};

struct SequenceOptions {
    std::optional<std::uint64_t> start, end;  ///< inclusive range of frame numbers
    bool skip_existing = false;               ///< skip frames whose outputs all exist (resume)
    bool quiet = false;                       ///< report failures only
    bool progress_bar = false;                ///< a live bar (stderr is a terminal) instead of lines
};

/// The frames of a run: those of `input` (a pattern) in the range, less those skipped.
struct SequencePlan {
    std::vector<FrameJob> jobs;
    std::size_t selected = 0;  ///< frames in the range
    std::size_t skipped = 0;   ///< of those, skipped because their outputs exist
};

/// Finds the frames to process; throws (UsageError, trilevel::Error) before any work is done.
/// `output` and `stats` are patterns too (`stats` may be empty).
SequencePlan plan_frame_sequence(const std::string& input, const std::string& output, const std::string& stats,
                                 const SequenceOptions& options);

/// The message a failed frame reports for what it threw ("out of memory" for std::bad_alloc).
std::string failure_message(std::exception_ptr error);

/// Progress and summary of a run over planned frames, fed in frame order (from any one thread at
/// a time): a bar on a terminal, else one line per frame on stdout; one stderr line per failure;
/// then a summary with the share of coarse cells that changed level between consecutive frames.
class SequenceReport {
public:
    SequenceReport(const SequencePlan& plan, const SequenceOptions& options);
    ~SequenceReport();
    /// The bar names the frame being worked on (frames can take seconds each).
    void started(const FrameJob& job);
    void ok(const FrameJob& job, const FrameResult& result);
    void failed(const FrameJob& job, const std::string& message);
    /// Prints the summary; returns the exit status: 0 when no frame failed, 1 otherwise.
    int finish();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// Processes the planned frames in order, one at a time: `work` turns a job into its outputs; a
/// std::exception it throws fails that frame only. Reports as SequenceReport; returns its status.
int run_frame_sequence(const SequencePlan& plan, const SequenceOptions& options,
                       const std::function<FrameResult(const FrameJob&)>& work);

}  // namespace trilevel::cli
