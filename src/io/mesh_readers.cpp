// read_mesh: .ply (ascii or binary), .obj, legacy .vtk POLYDATA; enough to read back what
// write_mesh writes and common variants of it (polygons are fan-triangulated).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "io/io_common.hpp"
#include "io/particle_formats.hpp"
#include "io/ply_format.hpp"
#include "trilevel/io.hpp"

namespace trilevel {
namespace io {
namespace {

/// A value read from the file, short enough for a message (1e300 too).
std::string number_text(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.10g", v);
    return buf;
}

void add_polygon(const std::string& path, const std::string& where, const std::vector<std::int64_t>& idx, Mesh& mesh) {
    for (std::int64_t v : idx)
        if (v < 0 || static_cast<std::uint64_t>(v) >= mesh.vertex_count())
            fail(path, where + ": vertex index " + std::to_string(v) + " out of range");
    for (std::size_t j = 1; j + 1 < idx.size(); ++j)
        for (std::size_t c : {std::size_t(0), j, j + 1}) mesh.triangles.push_back(static_cast<std::uint32_t>(idx[c]));
}

void read_ply_vertices(const std::string& path, PlyValueReader& r, const PlyElement& e, Mesh& mesh) {
    for (const char* c : {"x", "y", "z"})
        if (std::none_of(e.props.begin(), e.props.end(), [&](const PlyProperty& p) { return p.name == c && !p.list_count; }))
            fail(path, "PLY vertex element lacks property x, y or z");
    mesh.positions.reserve(3 * std::min<std::uint64_t>(e.count, r.left()));
    for (std::uint64_t i = 0; i < e.count; ++i) {
        float xyz[3] = {0, 0, 0};
        for (const auto& p : e.props) {
            const int c = p.name == "x" ? 0 : p.name == "y" ? 1 : p.name == "z" ? 2 : -1;
            if (p.list_count || (c < 0 && p.name != "level")) { r.skip(p); continue; }
            const double v = r.next(p.type);
            if (c >= 0) {
                xyz[c] = to_float_checked(path, v, mesh.positions.size() + c);
            } else {
                if (!(v >= 0 && v <= 255)) fail(path, r.where() + ": vertex level " + number_text(v) + " out of range 0..255");
                mesh.vertex_level.push_back(static_cast<std::uint8_t>(v));
            }
        }
        mesh.positions.insert(mesh.positions.end(), xyz, xyz + 3);
    }
}

void read_ply_faces(const std::string& path, PlyValueReader& r, const PlyElement& e, Mesh& mesh) {
    std::vector<std::int64_t> idx;
    for (std::uint64_t i = 0; !e.props.empty() && i < e.count; ++i)
        for (const auto& p : e.props) {
            if (!p.list_count || (p.name != "vertex_indices" && p.name != "vertex_index")) { r.skip(p); continue; }
            const std::string where = r.where();
            idx.resize(r.list_length(*p.list_count));
            for (auto& v : idx) {
                const double x = r.next(p.type);  // range-checked before the cast: a double may hold anything
                if (!(x >= 0 && x < static_cast<double>(mesh.vertex_count())))
                    fail(path, where + ": vertex index " + number_text(x) + " out of range");
                v = static_cast<std::int64_t>(x);
            }
            add_polygon(path, where, idx, mesh);
        }
}

Mesh read_ply_mesh(const std::string& path, const std::string& data) {
    const PlyHeader h = parse_ply_header(path, data);
    PlyValueReader r(path, data, h);
    Mesh mesh;
    for (const auto& e : h.elements) {
        if (e.name == "vertex") read_ply_vertices(path, r, e, mesh);
        else if (e.name == "face") read_ply_faces(path, r, e, mesh);
        else for (std::uint64_t i = 0; !e.props.empty() && i < e.count; ++i) for (const auto& p : e.props) r.skip(p);
    }
    return mesh;
}

/// One index of an OBJ face corner ("7", "7/1", "7//3", "-1"), 0-based.
std::int64_t obj_index(const std::string& path, std::size_t line, std::string_view tok, std::size_t nv) {
    tok = tok.substr(0, tok.find('/'));
    double v;
    if (!parse_double(tok, v) || v == 0 || v != std::floor(v))
        fail(path, "line " + std::to_string(line) + ": bad face index '" + std::string(tok) + "'");
    if (std::fabs(v) > static_cast<double>(nv))  // before the cast, which a huge value would overflow
        fail(path, "line " + std::to_string(line) + ": face index '" + std::string(tok) + "' out of range");
    return v > 0 ? static_cast<std::int64_t>(v) - 1 : static_cast<std::int64_t>(nv) + static_cast<std::int64_t>(v);
}

Mesh read_obj_mesh(const std::string& path, const std::string& data) {
    Mesh mesh;
    std::vector<std::int64_t> idx;
    std::size_t pos = 0, line = 0;
    while (pos < data.size()) {
        std::size_t nl = data.find('\n', pos);
        if (nl == std::string::npos) nl = data.size();
        const auto t = split_ws(std::string_view(data.data() + pos, nl - pos));
        pos = nl + 1;
        ++line;
        if (t.empty()) continue;
        const std::string at = "line " + std::to_string(line);
        if (t[0] == "v") {
            if (t.size() < 4) fail(path, at + ": expected v <x> <y> <z>");
            for (int k = 1; k <= 3; ++k) {
                double v;
                if (!parse_double(t[k], v)) fail(path, at + ": malformed number '" + std::string(t[k]) + "'");
                mesh.positions.push_back(to_float_checked(path, v, mesh.positions.size()));
            }
        } else if (t[0] == "f") {
            idx.clear();
            for (std::size_t k = 1; k < t.size(); ++k) idx.push_back(obj_index(path, line, t[k], mesh.vertex_count()));
            if (idx.size() < 3) fail(path, at + ": a face needs at least 3 vertices");
            add_polygon(path, at, idx, mesh);
        }
    }
    return mesh;
}

}  // namespace
}  // namespace io

Mesh read_mesh(const std::string& path) {
    using namespace io;
    require_file(path);  // a missing file is reported as such, whatever its name
    const std::string ext = extension_of(path);
    if (ext != "ply" && ext != "obj" && ext != "vtk")
        fail(path, "unknown mesh file extension '" + ext + "', expected .ply, .obj or .vtk");
    const std::string data = read_file(path);
    return read_mesh_from_memory(ext, path, data);
}

/// `ext` is ply, obj or vtk: read_mesh has checked it.
Mesh io::read_mesh_from_memory(const std::string& ext, const std::string& path, const std::string& data) {
    Mesh mesh = ext == "ply" ? read_ply_mesh(path, data) : ext == "obj" ? read_obj_mesh(path, data) : read_vtk_mesh(path, data);
    if (!mesh.vertex_level.empty() && mesh.vertex_level.size() != mesh.vertex_count())
        fail(path, "vertex level count does not match the vertex count");
    return mesh;
}

}  // namespace trilevel
