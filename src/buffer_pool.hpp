// Device buffers kept across frames (docs/design.md §4 and §9: buffers and kernels reused across frames).
// OpenCLRuntime::buffer lends buffers from a BufferPool keyed by role ("particle order", "fine
// point hash", ...); a DeviceBuffer gives its buffer back to the pool when it is destroyed, and the
// next request of the same role takes it again when it is large enough. A buffer's content is
// whatever its last user left: every stage fills (hash tables, counters, NaN values) or writes the
// range it reads, so a reused buffer gives the same results as a fresh one.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <CL/opencl.hpp>

namespace trilevel {

/// A pool buffer on loan: a cl::Buffer (so it is a kernel argument as it is) that goes back to its
/// pool when destroyed or assigned over. Move-only: the loan has one owner. Do not keep a copy of
/// the cl::Buffer beyond the DeviceBuffer: the pool lends it again once the loan ends.
class DeviceBuffer : public cl::Buffer {
public:
    struct Loan {
        bool active = false;
        std::size_t bytes = 0;  ///< what the borrower asked for (the buffer may be larger)
    };
    DeviceBuffer() = default;
    DeviceBuffer(const cl::Buffer& buffer, std::shared_ptr<Loan> loan) : cl::Buffer(buffer), loan_(std::move(loan)) {}
    DeviceBuffer(DeviceBuffer&& o) noexcept : cl::Buffer(std::move(o)), loan_(std::move(o.loan_)) {}
    DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
        if (this != &o) {
            give_back();
            cl::Buffer::operator=(std::move(o));
            loan_ = std::move(o.loan_);
        }
        return *this;
    }
    DeviceBuffer(const DeviceBuffer&) = delete;
    DeviceBuffer& operator=(const DeviceBuffer&) = delete;
    ~DeviceBuffer() { give_back(); }

private:
    void give_back() noexcept {
        if (loan_) loan_->active = false;
        loan_.reset();
    }
    std::shared_ptr<Loan> loan_;
};

/// The bookkeeping of pooled buffers; OpenCLRuntime::buffer does the checks and the allocation.
/// A role may hold several buffers (two fine-point tables live at once while one is rehashed into
/// the other). Not thread-safe: one pool per runtime, one runtime per thread.
class BufferPool {
public:
    struct Entry {
        std::string role;
        cl_mem_flags flags = 0;
        cl::Buffer buffer;
        std::size_t capacity = 0;  ///< bytes of `buffer` (0: none yet)
        std::shared_ptr<DeviceBuffer::Loan> loan = std::make_shared<DeviceBuffer::Loan>();
        std::size_t frame_need = 0;  ///< largest loan of this frame
        int slack_frames = 0;        ///< consecutive frames that needed less than half of `capacity`
        bool free() const { return !loan->active; }
    };

    /// Frames in a row a buffer may stay more than twice as large as any loan of it (or unused)
    /// before end_frame releases it: a large frame followed by small ones keeps its buffers for a
    /// while (a sequence that goes back up reuses them), not for ever.
    static constexpr int kTrimFrames = 16;
    /// Growth factor when a role outgrows its buffer, so that a slowly growing sequence does not
    /// allocate every frame (taken only within the memory budget).
    static constexpr double kGrowth = 1.5;

    BufferPool() = default;
    BufferPool(const BufferPool&) = delete;
    BufferPool& operator=(const BufferPool&) = delete;
    ~BufferPool() { clear(); }

    /// The free buffer of `role` to lend for `bytes`: the smallest free one that holds `bytes`,
    /// else the largest free one (to be replaced by a larger buffer), else a new empty entry.
    Entry& find(const std::string& role, cl_mem_flags flags, std::size_t bytes);
    /// Lends the entry's buffer for `bytes` (which it must hold).
    DeviceBuffer lend(Entry& e, std::size_t bytes);
    /// Puts a newly allocated buffer of `capacity` bytes into the (free, empty) entry.
    void install(Entry& e, const cl::Buffer& buffer, std::size_t capacity);
    /// Drops the entry's buffer (it must be free); the entry stays for the next allocation.
    void drop(Entry& e);
    /// Releases free buffers other than `keep`; `only_idle`: only those not lent this frame.
    /// Returns the bytes released.
    std::uint64_t release_free(bool only_idle, const Entry* keep = nullptr);
    /// End of a frame: trims the buffers kTrimFrames frames oversized and starts the next frame.
    void end_frame();
    /// Releases every buffer (after a failed frame, or to give the memory back). Buffers still
    /// on loan are only forgotten: their DeviceBuffer releases them.
    void clear();

    std::uint64_t held_bytes() const;  ///< capacity of every pooled buffer
    std::uint64_t lent_bytes() const;  ///< bytes asked for by the loans active now
    std::size_t buffers() const;       ///< pooled buffers (allocated entries)

private:
    void erase_empty();
    std::vector<std::unique_ptr<Entry>> entries_;
};

/// Bytes and number of the device buffers held by the pools of every runtime in the process (lent
/// or free). Between frames every live device buffer (live_device_buffers) is a pooled one.
std::int64_t pooled_device_bytes();
std::int64_t pooled_device_buffers();

}  // namespace trilevel
