// The fuzz targets' body: one libFuzzer target per reader, TRILEVEL_FUZZ_FORMAT naming the particle
// format ("vtk", "vtu", "bgeo", "ply", "xyz": the format's reader as read_particles calls it) or
// "mesh" for read_mesh (PLY, OBJ or legacy VTK, told apart by the first bytes). The input is the
// whole file, in memory; a particle reader reads it twice, as read_particles would without and with
// attributes. Without TRILEVEL_FUZZ_FORMAT this is the body of trilevel_fuzz_replay (replay.cpp).
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

/// Readers return whole x, y, z triplets, of finite floats unless NaN/Inf are kept on request.
void check_positions(const std::vector<float>& xyz, bool finite) {
    if (xyz.size() % 3 != 0) broken("positions are not x, y, z triplets");
    for (float c : xyz)
        if (finite && !std::isfinite(c)) broken("non-finite coordinate");
}

/// read_mesh returns triangles indexing existing vertices and one level per vertex when any.
void check_mesh(const trilevel::Mesh& mesh) {
    check_positions(mesh.positions, true);
    if (mesh.triangles.size() % 3 != 0) broken("triangle indices are not triplets");
    for (std::uint32_t v : mesh.triangles)
        if (v >= mesh.vertex_count()) broken("triangle index out of range");
    if (!mesh.vertex_level.empty() && mesh.vertex_level.size() != mesh.vertex_count()) broken("level count");
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) broken("normal count");
    for (const auto& a : mesh.attributes)
        if (a.values.size() != mesh.vertex_count() * static_cast<std::size_t>(a.components)) broken("attribute count");
}

using Reader = trilevel::ParticleSet (*)(const trilevel::io::ReadRequest&);

/// The particle reader read_particles picks for the format.
Reader particle_reader(const std::string& format) {
    using namespace trilevel::io;
    if (format == "vtk") return read_vtk;
    if (format == "vtu") return read_vtu;
    if (format == "bgeo") return read_bgeo;
    if (format == "ply") return read_ply;
    if (format == "xyz") return read_xyz;
    broken("unknown TRILEVEL_FUZZ_FORMAT");
}

/// Attributes come as whole tuples of 1 or 3 components per particle.
void check_attributes(const trilevel::ParticleSet& set) {
    for (const auto& a : set.attributes)
        if ((a.components != 1 && a.components != 3) || a.values.size() != set.size() * a.components)
            broken("attribute values do not match the particle count");
}

/// A rejection must be one line naming the file.
void check_error(const trilevel::Error& e) {
    const std::string msg = e.what();
    if (msg.rfind("fuzz.", 0) != 0 || msg.find('\n') != std::string::npos) broken("error message not one line naming the file");
}

/// Both ways read_particles uses a reader: positions only with NaN/Inf an error, and with the
/// attributes the seeds carry asked for and NaN/Inf kept (ReadOptions::drop_invalid).
void fuzz_particles(const std::string& format, const std::string& data) {
    const std::string path = "fuzz." + format;
    const Reader read = particle_reader(format);
    try {
        check_positions(read({path, data, {}, false}).positions, true);
    } catch (const trilevel::Error& e) {
        check_error(e);
    }
    try {
        const auto set = read({path, data, {"velocity", "density"}, true});
        check_positions(set.positions, false);
        check_attributes(set);
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
