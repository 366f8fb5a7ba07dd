// The fuzz targets' body: one libFuzzer target per reader, TRILEVEL_FUZZ_FORMAT naming the particle
// format ("vtk", "vtu", "bgeo", "ply", "xyz": the format's reader as read_particles calls it) or
// "mesh" for read_mesh (PLY, OBJ or legacy VTK, told apart by the first bytes). The input is the
// whole file, in memory; read_particles_from_memory reads it twice, as read_particles would without
// and with attributes (and NaN/Inf dropping). Without TRILEVEL_FUZZ_FORMAT this is the body of
// trilevel_fuzz_replay (replay.cpp).
// trilevel::Error is the clean rejection; anything else is a finding: a crash, a sanitizer report,
// another exception (it escapes and aborts), a leak, a timeout, too much memory (run_fuzz.sh sets
// the limits), or a result that breaks what the readers promise (checked below, failing with abort()).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz_reader.hpp"
#include "io/particle_formats.hpp"

namespace {

[[noreturn]] void broken(const char* what) {
    std::fprintf(stderr, "trilevel fuzz: reader returned a bad result: %s\n", what);
    std::abort();
}

/// Readers return whole x, y, z triplets of finite floats (NaN/Inf fail, or are dropped on request).
void check_positions(const std::vector<float>& xyz) {
    if (xyz.size() % 3 != 0) broken("positions are not x, y, z triplets");
    for (float c : xyz)
        if (!std::isfinite(c)) broken("non-finite coordinate");
}

/// read_mesh returns triangles indexing existing vertices and one level per vertex when any.
void check_mesh(const trilevel::Mesh& mesh) {
    check_positions(mesh.positions);
    if (mesh.triangles.size() % 3 != 0) broken("triangle indices are not triplets");
    for (std::uint32_t v : mesh.triangles)
        if (v >= mesh.vertex_count()) broken("triangle index out of range");
    if (!mesh.vertex_level.empty() && mesh.vertex_level.size() != mesh.vertex_count()) broken("level count");
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) broken("normal count");
    for (const auto& a : mesh.attributes)
        if (a.values.size() != mesh.vertex_count() * static_cast<std::size_t>(a.components)) broken("attribute count");
}

/// The `count` distinct attributes asked for come in order, as whole tuples of 1 or 3 components.
void check_attributes(const trilevel::ParticleSet& set, std::size_t count) {
    if (set.attributes.size() != count) broken("not one attribute per distinct name asked for");
    for (const auto& a : set.attributes)
        if ((a.components != 1 && a.components != 3) || a.values.size() != set.size() * a.components)
            broken("attribute values do not match the particle count");
}

/// A rejection must be one line naming the file.
void check_error(const trilevel::Error& e) {
    const std::string msg = e.what();
    if (msg.rfind("fuzz.", 0) != 0 || msg.find('\n') != std::string::npos) broken("error message not one line naming the file");
}

/// read_particles' two common uses, from memory: positions only, NaN/Inf an error; and the
/// attributes the seeds carry (one asked twice) with NaN/Inf particles dropped (ReadOptions).
void fuzz_particles(const std::string& format, const std::string& data) {
    const std::string path = "fuzz." + format;
    try {
        check_positions(trilevel::io::read_particles_from_memory(format, path, data, {}).positions);
    } catch (const trilevel::Error& e) {
        check_error(e);
    }
    try {
        trilevel::ReadOptions options;
        options.attributes = {"velocity", "density", "velocity"};
        options.drop_invalid = true;
        const auto set = trilevel::io::read_particles_from_memory(format, path, data, options);
        check_positions(set.positions);
        check_attributes(set, 2);
    } catch (const trilevel::Error& e) {
        check_error(e);
    }
}

/// The reader read_mesh would pick for a file holding `data`: the fuzzer steers it by the magic.
std::string mesh_extension(const std::string& data) {
    if (data.compare(0, 3, "ply") == 0) return "ply";
    if (data.compare(0, 5, "# vtk") == 0) return "vtk";
    return "obj";
}

}  // namespace

void trilevel_fuzz_one(const std::string& format, const std::string& data) {
    if (format != "mesh") {
        fuzz_particles(format, data);
        return;
    }
    const std::string ext = mesh_extension(data);
    try {
        check_mesh(trilevel::io::read_mesh_from_memory(ext, "fuzz." + ext, data));
    } catch (const trilevel::Error& e) {
        check_error(e);
    }
}

#ifdef TRILEVEL_FUZZ_FORMAT
extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* bytes, std::size_t size) {
    trilevel_fuzz_one(TRILEVEL_FUZZ_FORMAT, std::string(reinterpret_cast<const char*>(bytes), size));
    return 0;
}
#endif
