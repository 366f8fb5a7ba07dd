// FramePipeline (trilevel/pipeline.hpp): a worker thread meshes, a sink thread hands meshes on;
// each hand-off is a rendezvous (one slot, the giver waits until the taker has it), so each stage
// holds one frame and the memory in flight stays one input and one mesh above a frame at a time.
// Where no memory limit is set and the device is not a CPU, a finisher thread between them runs
// frame k's host stages (triangulation, crack closing, post-processing) while the worker runs
// frame k+1's device stages (Reconstructor::mesh_then_finish).
#include "trilevel/pipeline.hpp"

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "environment.hpp"

namespace trilevel {

namespace {

/// A one-slot hand-off between two threads: put() waits for the slot to be free, then until the
/// taker has taken what it put; take() waits for something or for close().
template <class T>
class Rendezvous {
public:
    /// False when closed before the taker took it.
    bool put(T&& value) {
        std::unique_lock lock(m_);
        cv_.wait(lock, [&] { return !slot_ || closed_; });
        if (closed_) return false;
        slot_.emplace(std::move(value));
        const std::uint64_t ticket = ++put_count_;
        cv_.notify_all();
        cv_.wait(lock, [&] { return taken_count_ >= ticket || closed_; });
        return taken_count_ >= ticket;
    }
    /// Empty once closed and drained.
    std::optional<T> take() {
        std::unique_lock lock(m_);
        cv_.wait(lock, [&] { return slot_ || closed_; });
        if (!slot_) return std::nullopt;
        std::optional<T> v = std::move(slot_);
        slot_.reset();
        ++taken_count_;
        cv_.notify_all();
        return v;
    }
    /// No more put(); a take() still gets what is in the slot. `drop`: empty the slot too.
    void close(bool drop = false) {
        std::lock_guard lock(m_);
        closed_ = true;
        if (drop) slot_.reset();
        cv_.notify_all();
    }

private:
    std::mutex m_;
    std::condition_variable cv_;
    std::optional<T> slot_;
    std::uint64_t put_count_ = 0, taken_count_ = 0;
    bool closed_ = false;
};

std::uint64_t input_bytes(const std::vector<float>& xyz, const std::vector<ParticleAttribute>& attributes) {
    std::uint64_t b = xyz.size() * sizeof(float);
    for (const auto& a : attributes) b += a.values.size() * sizeof(float);
    return b;
}

std::uint64_t mesh_bytes(const Mesh& m) {
    std::uint64_t b = (m.positions.size() + m.normals.size()) * sizeof(float) + m.triangles.size() * sizeof(std::uint32_t) +
                      m.vertex_level.size() + m.triangle_kind.size();
    for (const auto& a : m.attributes) b += a.values.size() * sizeof(float);
    return b;
}

}  // namespace

struct FramePipeline::Impl {
    struct Input {
        std::uint64_t index = 0;
        std::vector<float> xyz;
        std::vector<ParticleAttribute> attributes;
        std::exception_ptr error;
    };

    /// A frame meshed, its post-processing still to run (`finish`, empty where it failed).
    struct Meshed {
        std::unique_ptr<PipelineFrame> frame;  // on the heap: `finish` writes its stats
        std::function<Mesh()> finish;
    };

    Reconstructor& rec;
    const Params params;
    const Sink sink;
    /// Whether frames go through the finisher, which triangulates and post-processes them: no
    /// memory limit is set (a frame in the finisher holds its cells, a host copy of its fine-point
    /// table, its mesh and its post-processing's arrays, which the limit's accounting does not
    /// count), and the device is not a CPU (environment.hpp, TRILEVEL_PIPELINE_FINISHER): a CPU
    /// device's stages keep the host's cores busy already.
    const bool overlap;
    Rendezvous<Input> to_worker;
    Rendezvous<Meshed> to_finisher;
    Rendezvous<PipelineFrame> to_sink;
    std::mutex m;
    std::exception_ptr sink_error;  ///< the first exception of the sink: the pipeline stops
    std::uint64_t pushed = 0;
    bool finished = false;
    std::thread worker, finisher, sink_thread;

    Impl(Reconstructor& r, const Params& p, Sink s)
        : rec(r),
          params(p),
          sink(std::move(s)),
          overlap(p.memory_limit_bytes == 0 && environment().pipeline_finisher.value_or(r.device().type != "CPU")) {
        sink_thread = std::thread([this] { sink_loop(); });
        if (overlap) finisher = std::thread([this] { finisher_loop(); });
        worker = std::thread([this] { worker_loop(); });
    }

    void worker_loop() {
        std::uint64_t held_mesh = 0;  // bytes of the mesh the sink holds (the previous frame's)
        while (std::optional<Input> in = to_worker.take()) {
            Meshed out{std::make_unique<PipelineFrame>(), {}};
            out.frame->index = in->index;
            out.frame->error = in->error;
            if (!out.frame->error) {
                try {
                    Params p = params;
                    if (p.memory_limit_bytes) p.memory_limit_bytes = frame_limit(held_mesh, input_bytes(in->xyz, in->attributes));
                    out.finish = rec.mesh_then_finish(std::move(in->xyz), p, out.frame->stats, std::move(in->attributes), overlap);
                } catch (...) {
                    out.frame->stats = Stats{};
                    out.frame->error = std::current_exception();
                }
            }
            in.reset();  // what the tail did not take over (a failed frame's input) before the hand-off
            if (overlap) {
                if (!to_finisher.put(std::move(out))) break;  // the sink failed: stop
                continue;
            }
            finish(out);
            held_mesh = mesh_bytes(out.frame->mesh);
            if (!to_sink.put(std::move(*out.frame))) break;  // the sink failed: stop
        }
        if (overlap) to_finisher.close();
        else to_sink.close();
    }

    /// Runs a frame's post-processing (its error in the frame, as the worker's).
    static void finish(Meshed& job) {
        if (!job.finish) return;
        try {
            job.frame->mesh = job.finish();
        } catch (...) {
            job.frame->mesh = Mesh{};
            job.frame->stats = Stats{};
            job.frame->error = std::current_exception();
        }
        job.finish = nullptr;  // the frame's positions and grid, before the hand-off
    }

    void finisher_loop() {
        while (std::optional<Meshed> job = to_finisher.take()) {
            finish(*job);
            if (!to_sink.put(std::move(*job->frame))) break;  // the sink failed: stop
        }
        to_sink.close();
    }

    /// The memory limit of a frame: the user's less the mesh the sink holds and the next input
    /// (reserved as large as this one).
    std::uint64_t frame_limit(std::uint64_t held_mesh, std::uint64_t next_input) const {
        const std::uint64_t limit = params.memory_limit_bytes, in_flight = held_mesh + next_input;
        constexpr std::uint64_t kSmallest = 4096;  // what Params validation accepts
        if (in_flight + kSmallest > limit)
            throw Error("memory limit of " + std::to_string(limit) + " bytes leaves nothing for this frame with " +
                        std::to_string(in_flight) +
                        " bytes in flight (the previous mesh being written and the next frame read ahead); raise "
                        "the limit or process one frame at a time");
        return limit - in_flight;
    }

    void sink_loop() {
        while (std::optional<PipelineFrame> f = to_sink.take()) {
            try {
                sink(*f);
            } catch (...) {
                {
                    std::lock_guard lock(m);
                    sink_error = std::current_exception();
                }
                to_sink.close(true);
                to_finisher.close(true);
                to_worker.close(true);
                return;
            }
        }
    }

    void rethrow_sink_error() {
        std::lock_guard lock(m);
        if (sink_error) std::rethrow_exception(sink_error);
    }

    void put(Input&& in) {
        if (finished) throw Error("FramePipeline: push after finish()");
        rethrow_sink_error();
        in.index = pushed++;
        to_worker.put(std::move(in));
        rethrow_sink_error();
    }

    void stop() {
        if (finished) return;
        finished = true;
        to_worker.close();
        worker.join();
        if (finisher.joinable()) finisher.join();
        sink_thread.join();
    }
};

FramePipeline::FramePipeline(Reconstructor& reconstructor, const Params& params, Sink sink) {
    check_params(params);  // at once, rather than in every frame's result
    impl_ = std::make_unique<Impl>(reconstructor, params, std::move(sink));
}

FramePipeline::~FramePipeline() {
    if (impl_) impl_->stop();
}

void FramePipeline::push(std::vector<float>&& xyz, std::vector<ParticleAttribute> attributes) {
    Impl::Input in;
    in.xyz = std::move(xyz);
    in.attributes = std::move(attributes);
    impl_->put(std::move(in));
}

void FramePipeline::push_failed(std::exception_ptr error) {
    Impl::Input in;
    in.error = error ? error : std::make_exception_ptr(Error("frame failed"));
    impl_->put(std::move(in));
}

void FramePipeline::finish() {
    impl_->stop();
    impl_->rethrow_sink_error();
}

}  // namespace trilevel
