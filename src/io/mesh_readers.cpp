// read_mesh: .ply (ascii or binary), .obj, legacy .vtk (POLYDATA, or UNSTRUCTURED_GRID of polygons); enough to read back what
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

/// Fan-triangulates a polygon whose indices the caller has range-checked.
void add_polygon(const std::vector<std::int64_t>& idx, Mesh& mesh) {
    for (std::size_t j = 1; j + 1 < idx.size(); ++j)
        for (std::size_t c : {std::size_t(0), j, j + 1}) mesh.triangles.push_back(static_cast<std::uint32_t>(idx[c]));
}

/// Attributes from the extra vertex properties, in order: `a_x a_y a_z` in a row make the vector
/// `a`, any other property a scalar (write_mesh's convention).
std::vector<VertexAttribute> group_attributes(const std::vector<std::string>& names, const std::vector<std::vector<float>>& columns) {
    std::vector<VertexAttribute> out;
    auto base = [](const std::string& n, const char* suffix) {
        return n.size() > 2 && n.compare(n.size() - 2, 2, suffix) == 0 ? n.substr(0, n.size() - 2) : std::string();
    };
    for (std::size_t i = 0; i < names.size();) {
        const std::string b = base(names[i], "_x");
        if (!b.empty() && i + 2 < names.size() && base(names[i + 1], "_y") == b && base(names[i + 2], "_z") == b) {
            VertexAttribute a{b, 3, std::vector<float>(3 * columns[i].size())};
            for (std::size_t v = 0; v < columns[i].size(); ++v)
                for (int c = 0; c < 3; ++c) a.values[3 * v + c] = columns[i + c][v];
            out.push_back(std::move(a));
            i += 3;
        } else {
            out.push_back({names[i], 1, columns[i]});
            ++i;
        }
    }
    return out;
}

/// x, y, z, optional nx, ny, nz (all three) and level; red, green, blue and lists are skipped;
/// every other scalar property is read as a float attribute.
void read_ply_vertices(const std::string& path, PlyValueReader& r, const PlyElement& e, Mesh& mesh) {
    auto has = [&](const char* c) {
        return std::any_of(e.props.begin(), e.props.end(), [&](const PlyProperty& p) { return p.name == c && !p.list_count; });
    };
    if (!has("x") || !has("y") || !has("z")) fail(path, "PLY vertex element lacks property x, y or z");
    const bool normals = has("nx") && has("ny") && has("nz");
    enum Role { Skip = -1, Level = -2, Attribute = -3 };  // >= 0: slot in xyz (0..2) or normal (3..5)
    std::vector<int> role;
    std::vector<std::string> names;
    for (const auto& p : e.props) {
        const std::string& n = p.name;
        if (p.list_count || n == "red" || n == "green" || n == "blue") role.push_back(Skip);
        else if (n == "x" || n == "y" || n == "z") role.push_back(n[0] - 'x');
        else if (normals && (n == "nx" || n == "ny" || n == "nz")) role.push_back(3 + n[1] - 'x');
        else if (n == "level") role.push_back(Level);
        else role.push_back(Attribute), names.push_back(n);
    }
    std::vector<std::vector<float>> columns(names.size());
    mesh.positions.reserve(3 * std::min<std::uint64_t>(e.count, r.left()));
    for (std::uint64_t i = 0; i < e.count; ++i) {
        float v6[6] = {0, 0, 0, 0, 0, 0};
        std::size_t column = 0;
        for (std::size_t k = 0; k < e.props.size(); ++k) {
            if (role[k] == Skip) { r.skip(e.props[k]); continue; }
            const double v = r.next(e.props[k].type);
            if (role[k] >= 3) {
                v6[role[k]] = narrow_to_float(v);
            } else if (role[k] >= 0) {
                v6[role[k]] = to_float_checked(path, v, mesh.positions.size() + role[k]);
            } else if (role[k] == Level) {
                if (!(v >= 0 && v <= 255)) fail(path, r.where() + ": vertex level " + number_text(v) + " out of range 0..255");
                mesh.vertex_level.push_back(static_cast<std::uint8_t>(v));
            } else {
                columns[column++].push_back(narrow_to_float(v));
            }
        }
        mesh.positions.insert(mesh.positions.end(), v6, v6 + 3);
        if (normals) mesh.normals.insert(mesh.normals.end(), v6 + 3, v6 + 6);
    }
    mesh.attributes = group_attributes(names, columns);
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
            add_polygon(idx, mesh);
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

/// `vn` lines are taken as per-vertex normals (write_mesh's convention) when there is one per `v`.
Mesh read_obj_mesh(const std::string& path, const std::string& data) {
    Mesh mesh;
    std::vector<float> normals;
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
        } else if (t[0] == "vn") {
            if (t.size() < 4) fail(path, at + ": expected vn <x> <y> <z>");
            for (int k = 1; k <= 3; ++k) {
                double v;
                if (!parse_double(t[k], v)) fail(path, at + ": malformed number '" + std::string(t[k]) + "'");
                normals.push_back(narrow_to_float(v));
            }
        } else if (t[0] == "f") {
            idx.clear();
            for (std::size_t k = 1; k < t.size(); ++k) idx.push_back(obj_index(path, line, t[k], mesh.vertex_count()));
            if (idx.size() < 3) fail(path, at + ": a face needs at least 3 vertices");
            add_polygon(idx, mesh);
        }
    }
    if (normals.size() == mesh.positions.size()) mesh.normals = std::move(normals);
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
    if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
        fail(path, "normal count does not match the vertex count");
    auto all_finite = [](const std::vector<float>& v) {
        return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
    };
    if (!all_finite(mesh.normals)) fail(path, "a vertex normal is not finite (NaN or Inf)");
    for (const auto& a : mesh.attributes) {
        if (a.values.size() != std::size_t(a.components) * mesh.vertex_count())
            fail(path, "vertex attribute '" + a.name + "' does not have one value per vertex");
        if (!all_finite(a.values)) fail(path, "vertex attribute '" + a.name + "' has a value that is not finite (NaN or Inf)");
    }
    return mesh;
}

}  // namespace trilevel
