#include "buffer_pool.hpp"

#include <algorithm>
#include <atomic>

namespace trilevel {
namespace {

std::atomic<std::int64_t> g_pooled_bytes{0}, g_pooled_buffers{0};

void count(std::size_t capacity, int sign) {
    if (capacity == 0) return;
    g_pooled_bytes.fetch_add(sign * std::int64_t(capacity), std::memory_order_relaxed);
    g_pooled_buffers.fetch_add(sign, std::memory_order_relaxed);
}

}  // namespace

std::int64_t pooled_device_bytes() { return g_pooled_bytes.load(std::memory_order_relaxed); }
std::int64_t pooled_device_buffers() { return g_pooled_buffers.load(std::memory_order_relaxed); }

BufferPool::Entry& BufferPool::find(const std::string& role, cl_mem_flags flags, std::size_t bytes) {
    Entry* fits = nullptr;     // smallest free buffer that holds `bytes`
    Entry* largest = nullptr;  // else the largest free one, to be replaced
    for (auto& e : entries_) {
        if (!e->free() || e->flags != flags || e->role != role) continue;
        if (e->capacity >= bytes && (!fits || e->capacity < fits->capacity)) fits = e.get();
        if (!largest || e->capacity > largest->capacity) largest = e.get();
    }
    if (fits) return *fits;
    if (largest) return *largest;
    auto e = std::make_unique<Entry>();
    e->role = role;
    e->flags = flags;
    entries_.push_back(std::move(e));
    return *entries_.back();
}

DeviceBuffer BufferPool::lend(Entry& e, std::size_t bytes) {
    e.loan->active = true;
    e.loan->bytes = bytes;
    e.frame_need = std::max(e.frame_need, bytes);
    return DeviceBuffer(e.buffer, e.loan);
}

void BufferPool::install(Entry& e, const cl::Buffer& buffer, std::size_t capacity) {
    drop(e);
    e.buffer = buffer;
    e.capacity = capacity;
    e.slack_frames = 0;
    count(capacity, +1);
}

void BufferPool::drop(Entry& e) {
    count(e.capacity, -1);
    e.buffer = cl::Buffer();
    e.capacity = 0;
}

std::uint64_t BufferPool::release_free(bool only_idle, const Entry* keep) {
    std::uint64_t released = 0;
    for (auto& e : entries_)
        if (e.get() != keep && e->free() && e->capacity && !(only_idle && e->frame_need)) {
            released += e->capacity;
            drop(*e);
        }
    return released;
}

void BufferPool::end_frame() {
    for (auto& e : entries_) {
        if (!e->free()) continue;  // lent across frames (a test holding a stage's output): keep it
        e->slack_frames = e->frame_need * 2 < e->capacity ? e->slack_frames + 1 : 0;
        if (e->slack_frames >= kTrimFrames) drop(*e);
        e->frame_need = 0;
    }
    erase_empty();
}

void BufferPool::clear() {
    for (auto& e : entries_) {
        if (e->free()) drop(*e);
        else {  // its borrower still holds the cl::Buffer, which releases it; no longer pooled
            count(e->capacity, -1);
            e->capacity = 0;
        }
    }
    entries_.clear();  // a live DeviceBuffer keeps its loan record (shared), not the entry
}

void BufferPool::erase_empty() {
    entries_.erase(std::remove_if(entries_.begin(), entries_.end(),
                                  [](const auto& e) { return e->free() && e->capacity == 0; }),
                   entries_.end());
}

std::uint64_t BufferPool::held_bytes() const {
    std::uint64_t sum = 0;
    for (const auto& e : entries_) sum += e->capacity;
    return sum;
}

std::uint64_t BufferPool::lent_bytes() const {
    std::uint64_t sum = 0;
    for (const auto& e : entries_)
        if (!e->free()) sum += e->loan->bytes;
    return sum;
}

std::size_t BufferPool::buffers() const {
    return std::size_t(std::count_if(entries_.begin(), entries_.end(), [](const auto& e) { return e->capacity > 0; }));
}

}  // namespace trilevel
