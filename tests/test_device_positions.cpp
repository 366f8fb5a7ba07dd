// Reconstructor on a caller's OpenCL context, device and queue, meshing positions from a cl_mem as
// a GPU simulator would hand them over: packed float3, float4 with a stride and an offset, after
// an event of another queue; bit-identical to the host-array path, level history included.
#include <cmath>
#include <limits>

#include <CL/cl.h>

#include "test_support.hpp"
#include "trilevel/io.hpp"

using trilevel::test::same_mesh;

namespace {

/// The OpenCL objects of a simulator: a context on the device the default Reconstructor picks,
/// an in-order queue (with or without profiling) and its buffers. Released on scope exit.
struct Simulator {
    cl_platform_id platform = nullptr;
    cl_device_id device = nullptr;
    cl_context context = nullptr;
    cl_command_queue queue = nullptr;
    std::vector<cl_mem> buffers;

    explicit Simulator(int index, cl_command_queue_properties props = 0) {
        cl_uint np = 0;
        REQUIRE(clGetPlatformIDs(0, nullptr, &np) == CL_SUCCESS);
        std::vector<cl_platform_id> platforms(np);
        clGetPlatformIDs(np, platforms.data(), nullptr);
        int seen = 0;  // the global index over all platforms, as trilevel::list_devices counts
        for (cl_platform_id p : platforms) {
            cl_uint nd = 0;
            if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 0, nullptr, &nd) != CL_SUCCESS) continue;
            std::vector<cl_device_id> devices(nd);
            clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, nd, devices.data(), nullptr);
            for (cl_device_id d : devices)
                if (seen++ == index) platform = p, device = d;
        }
        REQUIRE(device);
        cl_int err = CL_SUCCESS;
        context = clCreateContext(nullptr, 1, &device, nullptr, nullptr, &err);
        REQUIRE(err == CL_SUCCESS);
        const cl_queue_properties queue_props[] = {CL_QUEUE_PROPERTIES, props, 0};
        queue = clCreateCommandQueueWithProperties(context, device, queue_props, &err);
        REQUIRE(err == CL_SUCCESS);
    }
    ~Simulator() {
        for (cl_mem b : buffers) clReleaseMemObject(b);
        clReleaseCommandQueue(queue);
        clReleaseContext(context);
    }
    cl_mem buffer(const std::vector<float>& data) {
        cl_int err = CL_SUCCESS;
        cl_mem b = clCreateBuffer(context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, data.size() * sizeof(float),
                                  const_cast<float*>(data.data()), &err);
        REQUIRE(err == CL_SUCCESS);
        buffers.push_back(b);
        return b;
    }
};

/// Positions laid out as float4 (w = a marker) after `lead` floats of other data.
std::vector<float> as_float4(const std::vector<float>& xyz, std::size_t lead) {
    std::vector<float> out(lead, -7.0f);
    for (std::size_t i = 0; i < xyz.size() / 3; ++i) out.insert(out.end(), {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], 1000.0f});
    return out;
}

trilevel::Params params() {
    trilevel::Params p;
    p.particle_radius = 0.025f;
    p.level_hysteresis = 0.2f;
    return p;
}

}  // namespace

TEST_CASE("Device positions: float3 and float4 buffers of a caller's context give the host path's meshes", "[device_positions]") {
    trilevel::Reconstructor host;
    Simulator sim(host.device().index);
    trilevel::Reconstructor rec(sim.context, sim.device, sim.queue);
    CHECK(rec.device().name == host.device().name);
    const trilevel::Params p = params();
    for (int f = 0; f < 3; ++f) {  // three frames: the level history of the device path is the host's
        INFO("frame " << f);
        const std::vector<float> xyz = trilevel::generate_scene("falling-drop", 0.025f, 1, f).positions;
        const std::size_t n = xyz.size() / 3;
        trilevel::Stats hs, ds;
        const trilevel::Mesh expected = host.reconstruct(xyz.data(), n, p, &hs);
        trilevel::DevicePositions d;
        if (f != 1) {  // packed float3
            d.buffer = sim.buffer(xyz);
            d.count = n;
        } else {  // float4 after 5 leading floats: offset 20 bytes, stride 16
            d.buffer = sim.buffer(as_float4(xyz, 5));
            d.count = n;
            d.offset = 20;
            d.stride = 16;
        }
        const trilevel::Mesh got = rec.reconstruct(d, p, &ds);
        REQUIRE(got.triangle_count() > 0);
        CHECK(same_mesh(got, expected));
        CHECK(ds.closed);
        CHECK(ds.particles == n);
        CHECK(ds.level_flips == hs.level_flips);
        CHECK(ds.level_history == (f > 0));
        CHECK(ds.device_memory_bytes == hs.device_memory_bytes);  // the gather fills the upload's buffer
        CHECK(ds.kernel_ms.empty());  // the simulator's queue has no profiling: no kernel times
    }
}

TEST_CASE("Device positions: a block made on a lattice gets the host path's lattice phase", "[device_positions]") {
    // Layers at odd multiples of r: the lattice phase shifts the level-2 planes onto them
    // (reconstructor.cpp, lattice_phase_for; its effect: test_end_to_end.cpp, "a block made on a
    // lattice"), judged on every second particle here (8192 of them), which the device path reads
    // from the caller's float4 buffer: another phase would give another mesh.
    trilevel::Reconstructor host;
    Simulator sim(host.device().index);
    trilevel::Reconstructor rec(sim.context, sim.device, sim.queue);
    const float r = 0.025f;
    const auto block = trilevel::test::lattice_points(glm::ivec3(32, 16, 16), glm::vec3(r), 2 * r, 0.01f * r, 1);
    const std::vector<float> xyz(&block[0].x, &block[0].x + 3 * block.size());
    const std::size_t n = block.size();
    trilevel::Params p = params();
    p.particle_radius = r;
    const trilevel::Mesh expected = host.reconstruct(xyz.data(), n, p);
    trilevel::DevicePositions d;
    d.buffer = sim.buffer(as_float4(xyz, 3));
    d.count = n;
    d.offset = 12;
    d.stride = 16;
    CHECK(same_mesh(rec.reconstruct(d, p), expected));
}

TEST_CASE("Device positions: after an event of another queue, an offset into a larger buffer, normals", "[device_positions]") {
    trilevel::Reconstructor host;
    Simulator sim(host.device().index, CL_QUEUE_PROFILING_ENABLE);
    trilevel::Reconstructor rec(sim.context, sim.device, nullptr);  // a queue of its own on the context
    trilevel::Params p = params();
    const std::vector<float> xyz = trilevel::generate_scene("pool-and-drop", 0.025f, 3).positions;
    const std::size_t n = xyz.size() / 3;
    const std::vector<float> laid = as_float4(xyz, 8);
    cl_int err = CL_SUCCESS;
    cl_mem buf = clCreateBuffer(sim.context, CL_MEM_READ_WRITE, (laid.size() + 64) * sizeof(float), nullptr, &err);
    REQUIRE(err == CL_SUCCESS);
    sim.buffers.push_back(buf);
    // The simulator writes the positions on its own queue without waiting; the event orders the read.
    cl_event written = nullptr;
    REQUIRE(clEnqueueWriteBuffer(sim.queue, buf, CL_FALSE, 0, laid.size() * sizeof(float), laid.data(), 0, nullptr, &written) ==
            CL_SUCCESS);
    trilevel::DevicePositions d;
    d.buffer = buf;
    d.count = n;
    d.offset = 8 * sizeof(float);
    d.stride = 16;
    d.wait_for = {written};
    for (trilevel::NormalMode normals : {trilevel::NormalMode::Area, trilevel::NormalMode::Gradient}) {
        p.normals = normals;  // gradient normals read the particles back; area normals do not need them
        trilevel::Stats ds;
        host.reset_history();
        rec.reset_history();
        const trilevel::Mesh expected = host.reconstruct(xyz.data(), n, p);
        const trilevel::Mesh got = rec.reconstruct(d, p, &ds);
        CHECK(same_mesh(got, expected));
        CHECK(got.normals.size() == got.positions.size());
        CHECK_FALSE(ds.kernel_ms.empty());  // its own queue records kernel times
    }
    clReleaseEvent(written);  // not retained by the Reconstructor beyond the call

    // A radius of 2.5e-6 (the pipeline scales it on the host): the read-back path, same bits.
    std::vector<float> small = xyz;
    for (float& v : small) v *= 1e-4f;
    trilevel::Params q = params();
    q.particle_radius = 0.025f * 1e-4f;
    d = {};
    d.buffer = sim.buffer(small);
    d.count = n;
    host.reset_history();
    rec.reset_history();
    CHECK(same_mesh(rec.reconstruct(d, q), host.reconstruct(small.data(), n, q)));
}

TEST_CASE("Device positions: bad layouts, foreign buffers, non-finite coordinates and queues are one-line errors", "[device_positions]") {
    trilevel::Reconstructor host;
    Simulator sim(host.device().index);
    trilevel::Reconstructor rec(sim.context, sim.device, sim.queue);
    std::vector<float> xyz = trilevel::generate_scene("falling-drop", 0.025f, 1, 0).positions;
    const std::size_t n = xyz.size() / 3;
    const trilevel::Params p = params();
    trilevel::DevicePositions d;
    d.buffer = sim.buffer(xyz);
    d.count = n;
    d.stride = 16;
    CHECK_THROWS_WITH(rec.reconstruct(d, p), "device positions: " + std::to_string(n) + " particles at offset 0 and stride 16 need " +
                                                 std::to_string((n - 1) * 16 + 12) + " bytes, but the buffer holds " +
                                                 std::to_string(n * 12));
    d.stride = 14;
    CHECK_THROWS_WITH(rec.reconstruct(d, p), "device positions: stride of 14 bytes; it must be a multiple of 4 and at least 12 (x, y, z floats)");
    d.stride = 12;
    d.offset = 2;
    CHECK_THROWS_WITH(rec.reconstruct(d, p), "device positions: offset of 2 bytes is not a multiple of 4");
    d.offset = 0;
    d.count = 0;
    CHECK_THROWS_WITH(rec.reconstruct(d, p), "no particles to reconstruct (the input is empty)");

    xyz[3 * 1234 + 2] = std::numeric_limits<float>::infinity();
    xyz[3 * 4000] = std::numeric_limits<float>::quiet_NaN();
    d.buffer = sim.buffer(xyz);
    d.count = n;
    CHECK_THROWS_WITH(rec.reconstruct(d, p), "particle 1234 has a non-finite coordinate");
    CHECK_THROWS_WITH(host.reconstruct(xyz.data(), n, p), "particle 1234 has a non-finite coordinate");

    Simulator other(host.device().index);  // a second context: its buffers are not ours
    d.buffer = other.buffer(trilevel::generate_scene("falling-drop", 0.025f, 1, 0).positions);
    CHECK_THROWS_WITH(rec.reconstruct(d, p), "device positions: the buffer belongs to another OpenCL context than the Reconstructor's");
    CHECK_THROWS_WITH(trilevel::Reconstructor(sim.context, sim.device, other.queue),
                      "the OpenCL command queue belongs to another context or device than those given");
    // After the failures the Reconstructor meshes the next frame as the host path does.
    const std::vector<float> good = trilevel::generate_scene("falling-drop", 0.025f, 1, 1).positions;
    d.buffer = sim.buffer(good);
    rec.reset_history();
    CHECK(same_mesh(rec.reconstruct(d, p), host.reconstruct(good.data(), n, p)));

    cl_int err = CL_SUCCESS;
    const cl_queue_properties ooo_props[] = {CL_QUEUE_PROPERTIES, CL_QUEUE_OUT_OF_ORDER_EXEC_MODE_ENABLE, 0};
    cl_command_queue ooo = clCreateCommandQueueWithProperties(sim.context, sim.device, ooo_props, &err);
    if (err == CL_SUCCESS) {
        CHECK_THROWS_WITH(trilevel::Reconstructor(sim.context, sim.device, ooo),
                          "the OpenCL command queue executes out of order; give an in-order queue (or none: one is made)");
        clReleaseCommandQueue(ooo);
    }
    // The Reconstructor holds its own references: the simulator may release its handles first.
    trilevel::Reconstructor* late = nullptr;
    {
        Simulator gone(host.device().index);
        late = new trilevel::Reconstructor(gone.context, gone.device, gone.queue);
        d = {};
        d.buffer = gone.buffer(good);
        d.count = n;
        CHECK(same_mesh(late->reconstruct(d, p), host.reconstruct(good.data(), n, p)));
    }
    CHECK(late->reconstruct(good.data(), n, p).triangle_count() > 0);
    delete late;
}

TEST_CASE("Device positions: smoothing, sliver cleanup and attributes-free post-processing read the positions too", "[device_positions]") {
    // Smoothing weights read the particles on the host: the device path must hand them over (the
    // same mesh as the host path's), not a null pointer.
    trilevel::Reconstructor host;
    Simulator sim(host.device().index);
    trilevel::Reconstructor rec(sim.context, sim.device, sim.queue);
    trilevel::Params p = params();
    p.smooth = true;
    const std::vector<float> xyz = trilevel::generate_scene("falling-drop", 0.025f, 1, 0).positions;
    const std::size_t n = xyz.size() / 3;
    trilevel::Stats hs, ds;
    const trilevel::Mesh expected = host.reconstruct(xyz.data(), n, p, &hs);
    trilevel::DevicePositions d;
    d.buffer = sim.buffer(xyz);
    d.count = n;
    const trilevel::Mesh got = rec.reconstruct(d, p, &ds);
    REQUIRE(got.triangle_count() > 0);
    CHECK(same_mesh(got, expected));
    CHECK(ds.closed);
    CHECK(ds.sliver_edges_collapsed == hs.sliver_edges_collapsed);
}
