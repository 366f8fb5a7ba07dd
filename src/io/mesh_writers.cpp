// write_mesh: .ply (binary LE, optional per-vertex level and level colours), .obj, .vtk
// (legacy BINARY POLYDATA with a `level` point scalar). All writes are atomic and buffered.
#include <charconv>

#include "io/io_common.hpp"
#include "trilevel/io.hpp"

namespace trilevel {
namespace io {
namespace {

/// Checks what the writers rely on: whole triplets, indices in range, one level per vertex.
void check_mesh(const std::string& path, const Mesh& mesh) {
    if (mesh.positions.size() % 3 || mesh.triangles.size() % 3) fail(path, "mesh arrays are not triplets");
    if (!mesh.vertex_level.empty() && mesh.vertex_level.size() != mesh.vertex_count())
        fail(path, "mesh has " + std::to_string(mesh.vertex_level.size()) + " vertex levels for " +
                       std::to_string(mesh.vertex_count()) + " vertices");
    const std::size_t nv = mesh.vertex_count();
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
        if (mesh.triangles[i] >= nv)
            fail(path, "triangle " + std::to_string(i / 3) + " references vertex " + std::to_string(mesh.triangles[i]) +
                           ", the mesh has " + std::to_string(nv));
    check_finite(path, mesh.positions);
}

void level_colour(std::uint8_t level, char rgb[3]) {
    const unsigned char green[3] = {0, 170, 0}, blue[3] = {20, 90, 255}, grey[3] = {170, 170, 170};
    const unsigned char* c = level == 2 ? green : level == 3 ? blue : grey;
    for (int k = 0; k < 3; ++k) rgb[k] = static_cast<char>(c[k]);
}

void write_ply(AtomicWriter& out, const Mesh& mesh, const MeshWriteOptions& options) {
    const bool levels = options.vertex_level && !mesh.vertex_level.empty();
    const bool colours = options.color_levels && !mesh.vertex_level.empty();
    std::string head = "ply\nformat binary_little_endian 1.0\ncomment trilevel surface\nelement vertex " +
                       std::to_string(mesh.vertex_count()) + "\nproperty float x\nproperty float y\nproperty float z\n";
    if (levels) head += "property uchar level\n";
    if (colours) head += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    head += "element face " + std::to_string(mesh.triangle_count()) + "\nproperty list uchar uint vertex_indices\nend_header\n";
    out.write(head);
    if (!levels && !colours) {
        out.write(mesh.positions.data(), mesh.positions.size() * sizeof(float));
    } else {
        char rec[16];
        const std::size_t size = 12 + (levels ? 1 : 0) + (colours ? 3 : 0);
        for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
            std::memcpy(rec, &mesh.positions[3 * v], 12);
            std::size_t p = 12;
            if (levels) rec[p++] = static_cast<char>(mesh.vertex_level[v]);
            if (colours) level_colour(mesh.vertex_level[v], rec + p);
            out.write(rec, size);
        }
    }
    char face[13];
    face[0] = 3;
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
        std::memcpy(face + 1, &mesh.triangles[3 * t], 12);
        out.write(face, 13);
    }
}

/// Appends the shortest text that reads back as exactly the same float.
void append_float(std::string& s, float v) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    s.append(buf, r.ptr);
}

void write_obj(AtomicWriter& out, const Mesh& mesh) {
    std::string s = "# trilevel surface\n";
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
        s += "v";
        for (int k = 0; k < 3; ++k) { s += ' '; append_float(s, mesh.positions[3 * v + k]); }
        s += '\n';
        if (s.size() > (1 << 20)) { out.write(s); s.clear(); }
    }
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
        s += "f";
        for (int k = 0; k < 3; ++k) { s += ' '; s += std::to_string(std::uint64_t(mesh.triangles[3 * t + k]) + 1); }
        s += '\n';
        if (s.size() > (1 << 20)) { out.write(s); s.clear(); }
    }
    out.write(s);
}

void write_vtk(AtomicWriter& out, const std::string& path, const Mesh& mesh) {
    const std::size_t nv = mesh.vertex_count(), nt = mesh.triangle_count();
    if (4 * nt > 0x7fffffff) fail(path, "too many triangles for a legacy VTK file; write .ply");
    out.write("# vtk DataFile Version 4.2\ntrilevel surface\nBINARY\nDATASET POLYDATA\nPOINTS " + std::to_string(nv) + " float\n");
    write_floats(out, mesh.positions.data(), mesh.positions.size(), true);
    out.write("\nPOLYGONS " + std::to_string(nt) + " " + std::to_string(4 * nt) + "\n");
    std::vector<char> chunk(std::size_t(1) << 20);
    for (std::size_t t = 0; t < nt;) {
        const std::size_t m = std::min(nt - t, chunk.size() / 16);
        for (std::size_t k = 0; k < m; ++k) {
            store<std::int32_t>(chunk.data() + 16 * k, 3, true);
            for (int c = 0; c < 3; ++c)
                store<std::int32_t>(chunk.data() + 16 * k + 4 + 4 * c, static_cast<std::int32_t>(mesh.triangles[3 * (t + k) + c]), true);
        }
        out.write(chunk.data(), 16 * m);
        t += m;
    }
    out.write("\n");
    if (mesh.vertex_level.empty()) return;
    out.write("POINT_DATA " + std::to_string(nv) + "\nSCALARS level unsigned_char 1\nLOOKUP_TABLE default\n");
    out.write(mesh.vertex_level.data(), nv);
    out.write("\n");
}

}  // namespace
}  // namespace io

void write_mesh(const std::string& path, const Mesh& mesh, const MeshWriteOptions& options) {
    using namespace io;
    const std::string ext = extension_of(path);
    if (ext != "ply" && ext != "obj" && ext != "vtk")
        fail(path, "unknown mesh output extension '" + ext + "', expected .ply, .obj or .vtk");
    check_mesh(path, mesh);
    AtomicWriter out(path);
    if (ext == "ply") write_ply(out, mesh, options);
    else if (ext == "obj") write_obj(out, mesh);
    else write_vtk(out, path, mesh);
    out.commit();
}

}  // namespace trilevel
