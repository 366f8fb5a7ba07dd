// The device buffer pool (buffers reused across frames): what it lends again,
// how it grows, trims and releases, the budget on what is lent at once, and that reused buffers
// give the meshes of fresh ones.
#include <algorithm>
#include <set>
#include <vector>

#include "buffer_pool.hpp"
#include "opencl_runtime.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"
#include "trilevel/trilevel.hpp"

using namespace trilevel;

using trilevel::test::frame_memory_need;
using trilevel::test::same_mesh;

namespace {

/// A runtime of its own with an empty pool and no budget beyond the device's.
OpenCLRuntime& fresh_runtime(std::uint64_t budget = 0) {
    static OpenCLRuntime rt(-1);
    rt.release_buffers();
    rt.reset_budget(budget);
    return rt;
}

Params with_radius(float r, Mode mode = Mode::Adaptive) {
    Params p;
    p.particle_radius = r;
    p.mode = mode;
    return p;
}

}  // namespace

TEST_CASE("the pool lends a free buffer of the role again and grows it by half when outgrown", "[pool]") {
    OpenCLRuntime& rt = fresh_runtime();
    const std::int64_t a0 = device_buffer_allocations();
    cl_mem first = nullptr;
    {
        DeviceBuffer b = rt.buffer(1000, "test role");
        first = b();
    }
    {
        DeviceBuffer b = rt.buffer(800, "test role");  // fits: the same buffer
        CHECK(b() == first);
    }
    CHECK(device_buffer_allocations() == a0 + 1);
    {
        DeviceBuffer b = rt.buffer(1200, "test role");  // outgrown: replaced by one of 1.5 x 1000
        // (not b() != first: the old buffer is released first, and a driver may hand out the same
        // handle again, as NVIDIA's does)
        CHECK(b.getInfo<CL_MEM_SIZE>() == 1500);
        CHECK(device_buffer_allocations() == a0 + 2);
        CHECK(rt.pool().held_bytes() == 1500);
    }
    { DeviceBuffer b = rt.buffer(1400, "test role"); }
    CHECK(device_buffer_allocations() == a0 + 2);
    {
        DeviceBuffer b = rt.buffer(5000, "test role");  // more than 1.5x: what was asked
        CHECK(rt.pool().held_bytes() == 5000);
    }
    {  // two loans of one role at once get two buffers; another role or other flags get their own
        DeviceBuffer x = rt.buffer(100, "test role"), y = rt.buffer(100, "test role");
        DeviceBuffer z = rt.buffer(100, "other role"), w = rt.buffer(100, "test role", CL_MEM_READ_ONLY);
        const std::vector<cl_mem> ids{x(), y(), z(), w()};
        CHECK(std::set<cl_mem>(ids.begin(), ids.end()).size() == 4);
        CHECK(rt.pool().buffers() == 4);
        CHECK(rt.pool().lent_bytes() == 400);
    }
    CHECK(rt.pool().lent_bytes() == 0);
    {  // moving a loan moves its ownership; assigning over a loan gives the old buffer back
        DeviceBuffer a = rt.buffer(100, "other role");
        DeviceBuffer b = std::move(a);
        CHECK(rt.pool().lent_bytes() == 100);
        b = rt.buffer(50, "test role");
        CHECK(rt.pool().lent_bytes() == 50);
    }
    CHECK(rt.pool().lent_bytes() == 0);
}

TEST_CASE("the budget bounds the bytes lent at once, not the sum of a frame's requests", "[pool][memory]") {
    OpenCLRuntime& rt = fresh_runtime(4096);
    { DeviceBuffer a = rt.buffer(3000, "role a"); }
    {
        DeviceBuffer b = rt.buffer(3000, "role b");  // 6000 requested in all, 3000 at once
        CHECK(rt.pool().held_bytes() <= 4096);       // a's free buffer made room
    }
    CHECK(rt.peak_lent_bytes() == 3000);
    DeviceBuffer a = rt.buffer(3000, "role a");
    CHECK(rt.pool().held_bytes() <= 4096);
    REQUIRE_THROWS_WITH(rt.buffer(2000, "role b"),
                        Catch::Contains("the role b would bring device memory to") && Catch::Contains("over the budget of"));
    CHECK(rt.peak_lent_bytes() == 3000);
}

TEST_CASE("pooled buffers oversized or unused for BufferPool::kTrimFrames frames are released", "[pool]") {
    OpenCLRuntime& rt = fresh_runtime();
    {
        DeviceBuffer big = rt.buffer(100000, "trim big"), kept = rt.buffer(1000, "trim kept");
        DeviceBuffer gone = rt.buffer(2000, "trim unused");
    }
    rt.end_frame();
    auto small_frame = [&] {
        { DeviceBuffer k = rt.buffer(600, "trim kept"), b = rt.buffer(1000, "trim big"); }  // 600 >= 1000 / 2
        rt.end_frame();
    };
    for (int f = 1; f < BufferPool::kTrimFrames; ++f) small_frame();
    CHECK(rt.pool().held_bytes() == 103000);  // a sequence that goes back up would still find them
    small_frame();
    CHECK(rt.pool().held_bytes() == 1000);  // only the buffer that stayed in use at over half its size
    const std::int64_t a0 = device_buffer_allocations();
    { DeviceBuffer b = rt.buffer(1000, "trim big"); }  // allocated anew
    CHECK(device_buffer_allocations() == a0 + 1);
}

TEST_CASE("recovering from a failed frame releases every pooled buffer", "[pool]") {
    OpenCLRuntime& rt = fresh_runtime();
    const std::int64_t pooled = pooled_device_bytes();
    { DeviceBuffer b = rt.buffer(4096, "recover role"), c = rt.buffer(16, "recover role"); }
    CHECK(pooled_device_bytes() == pooled + 4096 + 16);
    CHECK(rt.pool().buffers() == 2);
    rt.recover();
    CHECK(rt.pool().buffers() == 0);
    CHECK(pooled_device_bytes() == pooled);
}

TEST_CASE("a Reconstructor reused across scenes of every size gives each scene's fresh mesh", "[pool][e2e]") {
    const float r = 0.025f;
    // Large, small, large again: each stage reuses buffers that held a larger or another scene.
    const char* scenes[] = {"dam-break", "sphere", "pool-and-drop", "block", "sphere", "dam-break"};
    for (Mode mode : {Mode::Adaptive, Mode::Uniform}) {
        Reconstructor reused;
        std::int64_t reused_allocations = 0, fresh_allocations = 0;
        for (const char* name : scenes) {
            INFO(name << (mode == Mode::Adaptive ? " adaptive" : " uniform"));
            const ParticleSet s = generate_scene(name, r, 3);
            reused.reset_history();  // levels as on a first frame, as in the fresh Reconstructor
            Stats st, fresh_st;
            std::int64_t a0 = device_buffer_allocations();
            const Mesh m = reused.reconstruct(s.positions.data(), s.size(), with_radius(r, mode), &st);
            reused_allocations += device_buffer_allocations() - a0;
            a0 = device_buffer_allocations();
            const Mesh expected = Reconstructor().reconstruct(s.positions.data(), s.size(), with_radius(r, mode), &fresh_st);
            fresh_allocations += device_buffer_allocations() - a0;
            REQUIRE(m.triangle_count() > 0);
            REQUIRE(same_mesh(m, expected));
            CHECK(st.device_memory_bytes == fresh_st.device_memory_bytes);  // whatever the pool held
        }
        INFO(reused_allocations << " allocations in 6 frames of one Reconstructor, " << fresh_allocations << " in fresh ones");
        CHECK(2 * reused_allocations < fresh_allocations);
    }
}

TEST_CASE("a first frame holds only its loans, and from the second on a Reconstructor pools its buffers", "[pool][memory]") {
    // A one-file run has nothing to reuse buffers for: its peak is what it lends at once, not the
    // sum of every stage's buffers. A sequence pays that sum from its second frame on and then
    // allocates nothing.
    const float r = 0.025f;
    const ParticleSet s = generate_scene("dam-break", r, 5);
    const std::int64_t pooled_before = pooled_device_bytes();
    Reconstructor rec;
    Stats first, second, third;
    const Mesh m1 = rec.reconstruct(s.positions.data(), s.size(), with_radius(r), &first);
    const std::int64_t after_first = pooled_device_bytes() - pooled_before;
    INFO("pooled after frame 1: " << after_first << " bytes; lent at most " << first.device_memory_bytes);
    CHECK(after_first < std::int64_t(first.device_memory_bytes) / 4);
    const Mesh m2 = rec.reconstruct(s.positions.data(), s.size(), with_radius(r), &second);
    CHECK(pooled_device_bytes() - pooled_before >= std::int64_t(second.device_memory_bytes));
    const std::int64_t a0 = device_buffer_allocations();
    const Mesh m3 = rec.reconstruct(s.positions.data(), s.size(), with_radius(r), &third);
    CHECK(device_buffer_allocations() == a0);
    CHECK(first.device_memory_bytes == second.device_memory_bytes);
    CHECK(same_mesh(m1, m2));
    CHECK(same_mesh(m1, m3));
}

TEST_CASE("a frame fits a memory limit of its own need (device buffers, mesh estimate) after larger frames", "[pool][memory]") {
    const float r = 0.025f;
    const ParticleSet big = generate_scene("dam-break", r, 4), small = generate_scene("sphere", r, 4);
    Stats need;
    const Mesh expected = Reconstructor().reconstruct(small.positions.data(), small.size(), with_radius(r), &need);
    REQUIRE(need.device_memory_bytes > 0);
    Reconstructor rec;
    rec.reconstruct(big.positions.data(), big.size(), with_radius(r));  // the pool now holds the large buffers
    Params limited = with_radius(r);
    limited.memory_limit_bytes = std::uint64_t(0.9 * double(need.device_memory_bytes));
    rec.reset_history();
    REQUIRE_THROWS_WITH(rec.reconstruct(small.positions.data(), small.size(), limited), Catch::Contains("over the budget"));
    rec.reconstruct(big.positions.data(), big.size(), with_radius(r));
    limited.memory_limit_bytes = frame_memory_need(need);
    rec.reset_history();
    Stats st;
    REQUIRE(same_mesh(rec.reconstruct(small.positions.data(), small.size(), limited, &st), expected));
    CHECK(st.device_memory_bytes == need.device_memory_bytes);
}

TEST_CASE("every memory limit below a frame's need stops it cleanly, wherever the budget runs out", "[pool][memory]") {
    const float r = 0.025f;
    const ParticleSet s = generate_scene("sphere", r, 6);
    Reconstructor rec;
    Stats need;
    const Mesh expected = rec.reconstruct(s.positions.data(), s.size(), with_radius(r), &need);
    // Steps of 1/64 of the need stop the frame in each stage, some with work still queued (whose
    // host data must outlive the error: the writes block).
    for (int k = 1; k < 64; ++k) {
        Params p = with_radius(r);
        p.memory_limit_bytes = std::max<std::uint64_t>(4096, need.device_memory_bytes * std::uint64_t(k) / 64);
        INFO("limit " << p.memory_limit_bytes << " of " << need.device_memory_bytes);
        REQUIRE_THROWS_WITH(rec.reconstruct(s.positions.data(), s.size(), p), Catch::Contains("over the budget"));
    }
    Params p = with_radius(r);
    p.memory_limit_bytes = frame_memory_need(need);
    rec.reset_history();
    REQUIRE(same_mesh(rec.reconstruct(s.positions.data(), s.size(), p), expected));
}
