// openvdb_mesh: the OpenVDB baseline for bench/run_bench.py.
//
//   openvdb_mesh IN.xyz OUT.ply --radius R [--voxel V] [--adaptivity A] [--threads T]
//                [--rmin VOXELS] [--half-width VOXELS] [--erode D]
//
// Reads raw float32 little-endian xyz triplets (particles.py convert IN OUT.xyz), rasterises
// every particle as a sphere of radius R into a narrow-band level set with voxel size V
// (default V = R) using tools::ParticlesToLevelSet, extracts the zero iso-surface with
// tools::volumeToMesh(grid, points, triangles, quads, 0.0, adaptivity), splits quads into two
// triangles and writes a binary little-endian PLY. Parallelism is capped with
// tbb::global_control (default 2 threads). Prints one JSON line of per-stage times (ms).
// --erode D: after rasterising, LevelSetFilter::offset(D) moves the surface inward by D world
// units (rasterise with a larger radius, rebuild the band as a true signed distance, then erode:
// a morphological closing of the spheres).
//
// ParticlesToLevelSet skips particles smaller than rMin voxels (default 1.5); with V = R a
// particle is 1 voxel, so rMin is lowered to 0.5 here (otherwise every particle is dropped).
#include <openvdb/openvdb.h>
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/LevelSetRebuild.h>
#include <openvdb/tools/ParticlesToLevelSet.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/global_control.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

struct ParticleList {
    using PosType = openvdb::Vec3R;
    std::vector<openvdb::Vec3R> pos;
    openvdb::Real radius = 0.0;
    size_t size() const { return pos.size(); }
    void getPos(size_t n, openvdb::Vec3R& xyz) const { xyz = pos[n]; }
    void getPosRad(size_t n, openvdb::Vec3R& xyz, openvdb::Real& rad) const {
        xyz = pos[n];
        rad = radius;
    }
};

double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

[[noreturn]] void fail(const std::string& msg) {
    std::fprintf(stderr, "openvdb_mesh: error: %s\n", msg.c_str());
    std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) fail("usage: openvdb_mesh IN.xyz OUT.ply --radius R [--voxel V] [--adaptivity A] [--threads T]");
    std::string in = argv[1], out = argv[2];
    double radius = 0.0, voxel = 0.0, adaptivity = 0.0, rmin = 0.5, half_width = 3.0, erode = 0.0;
    int threads = 2;
    for (int i = 3; i < argc; ++i) {
        std::string a = argv[i];
        auto next = [&]() -> double {
            if (i + 1 >= argc) fail("missing value for " + a);
            return std::atof(argv[++i]);
        };
        if (a == "--radius") radius = next();
        else if (a == "--voxel") voxel = next();
        else if (a == "--adaptivity") adaptivity = next();
        else if (a == "--threads") threads = static_cast<int>(next());
        else if (a == "--rmin") rmin = next();
        else if (a == "--half-width") half_width = next();
        else if (a == "--erode") erode = next();
        else fail("unknown option " + a);
    }
    if (!(radius > 0.0)) fail("--radius must be > 0");
    if (!(voxel > 0.0)) voxel = radius;
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));

    auto t_all = std::chrono::steady_clock::now();
    auto t0 = t_all;
    ParticleList pl;
    pl.radius = radius;
    {
        std::ifstream f(in, std::ios::binary | std::ios::ate);
        if (!f) fail("cannot open " + in);
        std::streamsize bytes = f.tellg();
        if (bytes % 12 != 0) fail("input size is not a multiple of 12 bytes (raw float32 xyz expected)");
        f.seekg(0);
        std::vector<float> raw(static_cast<size_t>(bytes / 4));
        if (!f.read(reinterpret_cast<char*>(raw.data()), bytes)) fail("cannot read " + in);
        pl.pos.resize(raw.size() / 3);
        for (size_t i = 0; i < pl.pos.size(); ++i) pl.pos[i] = openvdb::Vec3R(raw[3 * i], raw[3 * i + 1], raw[3 * i + 2]);
    }
    double t_read = ms_since(t0);

    openvdb::initialize();
    t0 = std::chrono::steady_clock::now();
    openvdb::FloatGrid::Ptr grid = openvdb::createLevelSet<openvdb::FloatGrid>(voxel, half_width);
    openvdb::tools::ParticlesToLevelSet<openvdb::FloatGrid> raster(*grid);
    raster.setRmin(rmin);
    raster.rasterizeSpheres(pl);
    raster.finalize(/*prune=*/true);
    if (erode != 0.0) {
        // The union of sphere level sets is a true distance only outside; inside it is too close to
        // zero, so rebuild the narrow band (with room for the offset) before eroding.
        grid = openvdb::tools::levelSetRebuild(*grid, 0.0f, static_cast<float>(half_width + erode / voxel + 1.0));
        openvdb::tools::LevelSetFilter<openvdb::FloatGrid> filter(*grid);
        filter.offset(static_cast<float>(erode));
    }
    double t_raster = ms_since(t0);
    size_t skipped = raster.getMinCount() + raster.getMaxCount();

    t0 = std::chrono::steady_clock::now();
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> tris;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(*grid, points, tris, quads, 0.0, adaptivity);
    double t_mesh = ms_since(t0);

    t0 = std::chrono::steady_clock::now();
    const size_t ntri = tris.size() + 2 * quads.size();
    {
        std::string tmp = out + ".tmp";
        std::ofstream f(tmp, std::ios::binary);
        if (!f) fail("cannot write " + tmp);
        std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(points.size()) +
                             "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                             std::to_string(ntri) + "\nproperty list uchar int vertex_indices\nend_header\n";
        f.write(header.data(), static_cast<std::streamsize>(header.size()));
        f.write(reinterpret_cast<const char*>(points.data()), static_cast<std::streamsize>(points.size() * sizeof(openvdb::Vec3s)));
        std::vector<char> buf;
        buf.reserve(ntri * 13);
        auto put = [&](uint32_t a, uint32_t b, uint32_t c) {
            char rec[13];
            rec[0] = 3;
            int32_t v[3] = {static_cast<int32_t>(a), static_cast<int32_t>(b), static_cast<int32_t>(c)};
            std::memcpy(rec + 1, v, 12);
            buf.insert(buf.end(), rec, rec + 13);
        };
        // volumeToMesh winds faces clockwise seen from outside (negative signed volume); reverse
        // them so the PLY is counter-clockwise / outward like trilevel's and splashsurf's.
        for (const auto& t : tris) put(t[0], t[2], t[1]);
        for (const auto& q : quads) {
            put(q[0], q[2], q[1]);
            put(q[0], q[3], q[2]);
        }
        f.write(buf.data(), static_cast<std::streamsize>(buf.size()));
        f.close();
        if (!f) fail("write failed: " + tmp);
        if (std::rename(tmp.c_str(), out.c_str()) != 0) fail("cannot rename to " + out);
    }
    double t_write = ms_since(t0);
    std::printf(
        "{\"particles\": %zu, \"skipped_particles\": %zu, \"active_voxels\": %llu, \"vertices\": %zu, "
        "\"triangles\": %zu, \"time_ms\": {\"read\": %.3f, \"rasterize\": %.3f, \"volume_to_mesh\": %.3f, "
        "\"write\": %.3f, \"total\": %.3f}, \"voxel\": %g, \"radius\": %g, \"adaptivity\": %g, \"erode\": %g, \"threads\": %d}\n",
        pl.size(), skipped, static_cast<unsigned long long>(grid->activeVoxelCount()), points.size(), ntri, t_read,
        t_raster, t_mesh, t_write, ms_since(t_all), voxel, radius, adaptivity, erode, threads);
    return 0;
}
