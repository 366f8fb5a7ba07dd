// A device buffer mapped for the host, the one way the pipeline maps buffers: on CPU devices
// (PoCL) a map is the buffer's own memory, no copy. The map ends with unmap() on the normal path
// (OpenCL errors propagate, and the stage fails with them) or when the guard goes, also when a
// stage throws, so that no buffer goes back to the pool, or the queue on to the next frame, mapped.
#pragma once

#include <cstddef>
#include <utility>

#include <CL/opencl.hpp>

#include "opencl_runtime.hpp"

namespace trilevel {

template <class T>
class MappedBuffer {
public:
    MappedBuffer() = default;
    /// Maps the first `count` elements of `buffer` (blocking) with `flags` (CL_MAP_READ, ...).
    MappedBuffer(OpenCLRuntime& rt, const cl::Buffer& buffer, std::size_t count, cl_map_flags flags)
        : queue_(rt.queue()),
          buffer_(buffer),
          data_(static_cast<T*>(queue_.enqueueMapBuffer(buffer_, CL_TRUE, flags, 0, count * sizeof(T)))) {}
    MappedBuffer(MappedBuffer&& o) noexcept
        : queue_(std::move(o.queue_)), buffer_(std::move(o.buffer_)), data_(std::exchange(o.data_, nullptr)) {}
    MappedBuffer& operator=(MappedBuffer&& o) noexcept {
        if (this != &o) {
            unmap_quietly();
            queue_ = std::move(o.queue_);
            buffer_ = std::move(o.buffer_);
            data_ = std::exchange(o.data_, nullptr);
        }
        return *this;
    }
    MappedBuffer(const MappedBuffer&) = delete;
    MappedBuffer& operator=(const MappedBuffer&) = delete;
    ~MappedBuffer() { unmap_quietly(); }

    /// Ends the map now (enqueued; the queue's next wait completes it) and drops this reference to
    /// the buffer, so that a buffer the pool frees is freed then, not when the guard goes (the
    /// unmap command holds it until it has run). Nothing when not mapped.
    void unmap() {
        if (!data_) return;
        T* p = std::exchange(data_, nullptr);
        queue_.enqueueUnmapMemObject(buffer_, p);
        buffer_ = cl::Buffer();
    }
    bool mapped() const { return data_ != nullptr; }
    T* data() const { return data_; }
    T& operator[](std::size_t i) const { return data_[i]; }

private:
    /// The destructor's unmap: a failing device has failed the frame already, and the queue
    /// reports that error; this one would only hide it.
    void unmap_quietly() noexcept {
        try {
            unmap();
        } catch (...) {
        }
    }

    cl::CommandQueue queue_;
    cl::Buffer buffer_;  ///< a reference to the mapped buffer (held while mapped), not a copy of its data
    T* data_ = nullptr;
};

}  // namespace trilevel
