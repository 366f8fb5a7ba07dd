// Pipelined frame sequences: the caller produces frame k+1 (a simulator steps it, the CLI reads
// its file) while frame k is meshed on a worker thread and frame k-1 is handed to a sink (written)
// on a third thread. The frames go through one Reconstructor in the order they were pushed, so
// the meshes (level history included) are bit-identical to calling Reconstructor::reconstruct
// frame by frame.
//
//   trilevel::Reconstructor rec;
//   trilevel::FramePipeline pipe(rec, params, [](trilevel::PipelineFrame& f) {
//       if (!f.error) write(f.index, f.mesh);      // on the sink thread, in push order
//       else report(f.index, f.error);             // a failed frame; the next ones go on
//   });
//   for (int step = 0; step < steps; ++step) {
//       simulate();
//       pipe.push(std::vector<float>(positions));  // returns once the previous frame is meshed
//   }
//   pipe.finish();                                 // every pushed frame has reached the sink
#pragma once

#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel {

/// One frame out of a FramePipeline.
struct PipelineFrame {
    std::uint64_t index = 0;   ///< order of the push (push or push_failed): 0, 1, 2, ...
    Mesh mesh;                 ///< empty when `error` is set
    Stats stats;               ///< what reconstruct reported (empty when `error` is set)
    std::exception_ptr error;  ///< the frame failed: what reconstruct threw, or what push_failed gave
};

/// Three stages, one frame in each: the caller's (producing frame k+1), the worker's (meshing
/// frame k with the Reconstructor) and the sink's (frame k-1). Where `params` set no memory limit
/// and the device is not a CPU (TRILEVEL_PIPELINE_FINISHER=0 or 1 overrides that), a fourth
/// stage, on its own thread, runs frame k's host stages (triangulation and crack closing from a
/// host copy of its fine-point table, then post-processing) while the worker runs frame k+1's
/// device stages; the meshes stay bit-identical. Memory: besides what one frame at a
/// time holds, one more input (the frame the caller produces) and one more mesh (the one in the
/// sink) are alive, and with the fourth stage the frame it triangulates (its cells, fine-point
/// table and mesh). With Params::memory_limit_bytes set, each frame is meshed under the limit less
/// the bytes of those two: the mesh the sink still holds (its exact size) and the next input (taken
/// as large as this frame's positions and attributes, which a steady sequence matches); a frame
/// whose limit leaves nothing fails with an Error saying so. Frames are never meshed two at a time,
/// so the device memory of one frame is all the pipeline needs.
class FramePipeline {
public:
    /// Receives every frame, in push order, on the pipeline's sink thread (one call at a time).
    /// It may move the mesh out. If it throws, the pipeline stops: push and finish rethrow that.
    using Sink = std::function<void(PipelineFrame& frame)>;

    /// `reconstructor` is used by the worker thread until finish() returns (or this is destroyed):
    /// do not call it, move it or destroy it meanwhile. Its level history carries on from before
    /// and on after. `params` apply to every frame; Error at once for parameters that every frame
    /// would refuse (check_params).
    FramePipeline(Reconstructor& reconstructor, const Params& params, Sink sink);
    /// finish(), with any error it would throw dropped.
    ~FramePipeline();
    FramePipeline(const FramePipeline&) = delete;
    FramePipeline& operator=(const FramePipeline&) = delete;

    /// Hands the next frame's positions (x, y, z per particle, world units) and attributes over.
    /// Returns once the worker has taken it, i.e. when the previous frame is meshed: the caller
    /// can then produce the frame after while this one is meshed. A frame that reconstruct
    /// rejects reaches the sink with PipelineFrame::error set; the frames after it go on.
    void push(std::vector<float>&& xyz, std::vector<ParticleAttribute> attributes = {});
    /// A frame the caller could not produce (a file that fails to read): it reaches the sink in its
    /// place in the order, with `error`, without touching the Reconstructor (its history stays
    /// that of the last frame meshed).
    void push_failed(std::exception_ptr error);
    /// Waits until every pushed frame has reached the sink; then stops the threads (no push after).
    void finish();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace trilevel
