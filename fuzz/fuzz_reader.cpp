// One libFuzzer target per reader: TRILEVEL_FUZZ_FORMAT names the particle format ("vtk", "vtu",
// "bgeo", "ply", "xyz": the format's reader as read_particles calls it) or "mesh" for read_mesh
// (PLY, OBJ or legacy VTK, told apart by the first bytes). The input is the whole file, in memory.
// trilevel::Error is the clean rejection; anything else is a finding: a crash, a sanitizer report, another exception (it escapes and
// aborts), a leak, a timeout, too much memory (run_fuzz.sh sets the limits), or a result that
// breaks what the readers promise (checked below, failing with abort()).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "io/particle_formats.hpp"

#ifndef TRILEVEL_FUZZ_FORMAT
#error "define TRILEVEL_FUZZ_FORMAT"
#endif

namespace {

[[noreturn]] void broken(const char* what) {
    std::fprintf(stderr, "trilevel fuzz: reader returned a bad result: %s\n", what);
    std::abort();
}

/// Readers return whole x, y, z triplets of finite floats.
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
}

/// The particle reader read_particles picks for the format (positions only: attributes are off).
std::vector<float> read_points(const std::string& format, const std::string& path, const std::string& data) {
    using namespace trilevel::io;
    if (format == "vtk") return read_vtk_points(path, data);
    if (format == "vtu") return read_vtu_points(path, data);
    if (format == "bgeo") return read_bgeo_points(path, data);
    if (format == "ply") return read_ply_points(path, data);
    if (format == "xyz") return read_xyz_points(path, data);
    broken("unknown TRILEVEL_FUZZ_FORMAT");
}

/// The reader read_mesh would pick for a file holding `data`: the fuzzer steers it by the magic.
std::string mesh_extension(const std::string& data) {
    if (data.compare(0, 3, "ply") == 0) return "ply";
    if (data.compare(0, 5, "# vtk") == 0) return "vtk";
    return "obj";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* bytes, std::size_t size) {
    const std::string data(reinterpret_cast<const char*>(bytes), size);
    const std::string format = TRILEVEL_FUZZ_FORMAT;
    try {
        if (format == "mesh") {
            const std::string ext = mesh_extension(data);
            check_mesh(trilevel::io::read_mesh_from_memory(ext, "fuzz." + ext, data));
        } else {
            check_positions(read_points(format, "fuzz." + format, data));
        }
    } catch (const trilevel::Error& e) {
        // a clean rejection, which must be one line naming the file
        const std::string msg = e.what();
        if (msg.rfind("fuzz.", 0) != 0 || msg.find('\n') != std::string::npos) broken("error message not one line naming the file");
    }
    return 0;
}
