// write_mesh: .ply (binary LE, optional per-vertex level and level colours), .obj, .vtk
// (legacy BINARY UNSTRUCTURED_GRID of triangles with a `level` point scalar), .vtp / .vtu (VTK XML PolyData /
// UnstructuredGrid, zlib-compressed base64 arrays). All writes are atomic and buffered.
// Normals: PLY nx ny nz, VTK VECTORS Normals, XML point data `Normals` (the active normals), OBJ vn.
// Attributes: PLY float properties `name` or `name_x name_y name_z`, VTK SCALARS / VECTORS, XML
// point data arrays; OBJ has no place for them and leaves them out.
#include <algorithm>
#include <charconv>
#include <cmath>

#include <zlib.h>

#include "io/io_common.hpp"
#include "trilevel/io.hpp"

namespace trilevel {
namespace io {
namespace {

std::vector<std::string> attribute_properties(const std::string& path, const Mesh& mesh);

/// Checks what the writers rely on: whole triplets, indices in range, one level per vertex, one
/// normal and finite values of every attribute per vertex, names every format can hold.
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
    if (!mesh.normals.empty() && mesh.normals.size() != 3 * nv)
        fail(path, "mesh has " + std::to_string(mesh.normals.size()) + " normal components for " + std::to_string(nv) + " vertices");
    for (float v : mesh.normals)
        if (!std::isfinite(v)) fail(path, "mesh has a non-finite normal");
    for (const auto& a : mesh.attributes) {
        if (a.components != 1 && a.components != 3)
            fail(path, "vertex attribute '" + a.name + "' has " + std::to_string(a.components) + " components, expected 1 or 3");
        if (a.values.size() != std::size_t(a.components) * nv)
            fail(path, "vertex attribute '" + a.name + "' has " + std::to_string(a.values.size()) + " values for " +
                           std::to_string(nv) + " vertices");
        for (float v : a.values)
            if (!std::isfinite(v)) fail(path, "vertex attribute '" + a.name + "' has a non-finite value");
    }
    attribute_properties(path, mesh);
}

/// The PLY property names of the attributes; Error for a name a PLY or VTK header cannot hold or
/// one that collides with another property (x, nx, level, red, ...), in any format alike so that
/// read_mesh tells them apart.
std::vector<std::string> attribute_properties(const std::string& path, const Mesh& mesh) {
    std::vector<std::string> taken = {"x", "y", "z", "nx", "ny", "nz", "level", "red", "green", "blue"}, out;
    for (const auto& a : mesh.attributes) {
        if (a.name.empty() || std::any_of(a.name.begin(), a.name.end(), [](unsigned char c) { return c <= ' ' || c == 127; }))
            fail(path, "vertex attribute name '" + a.name + "' is empty or holds white space or control characters");
        std::vector<std::string> names;
        if (a.components == 1) names = {a.name};
        else names = {a.name + "_x", a.name + "_y", a.name + "_z"};
        for (const auto& n : names) {
            if (std::find(taken.begin(), taken.end(), n) != taken.end())
                fail(path, "vertex attribute '" + a.name + "' collides with another vertex property named '" + n + "'");
            taken.push_back(n);
            out.push_back(n);
        }
    }
    return out;
}

void level_colour(std::uint8_t level, char rgb[3]) {
    const unsigned char green[3] = {0, 170, 0}, blue[3] = {20, 90, 255}, grey[3] = {170, 170, 170};
    const unsigned char* c = level == 2 ? green : level == 3 ? blue : grey;
    for (int k = 0; k < 3; ++k) rgb[k] = static_cast<char>(c[k]);
}

void write_ply(AtomicWriter& out, const std::string& path, const Mesh& mesh, const MeshWriteOptions& options) {
    const bool levels = options.vertex_level && !mesh.vertex_level.empty();
    const bool colours = options.color_levels && !mesh.vertex_level.empty();
    const bool normals = !mesh.normals.empty();
    const std::vector<std::string> attribute_names = attribute_properties(path, mesh);
    std::string head = "ply\nformat binary_little_endian 1.0\ncomment trilevel surface\nelement vertex " +
                       std::to_string(mesh.vertex_count()) + "\nproperty float x\nproperty float y\nproperty float z\n";
    if (normals) head += "property float nx\nproperty float ny\nproperty float nz\n";
    if (levels) head += "property uchar level\n";
    if (colours) head += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    for (const auto& n : attribute_names) head += "property float " + n + "\n";
    head += "element face " + std::to_string(mesh.triangle_count()) + "\nproperty list uchar uint vertex_indices\nend_header\n";
    out.write(head);
    if (!levels && !colours && !normals && attribute_names.empty()) {
        out.write(mesh.positions.data(), mesh.positions.size() * sizeof(float));
    } else {
        std::vector<char> rec(12 + (normals ? 12 : 0) + (levels ? 1 : 0) + (colours ? 3 : 0) + 4 * attribute_names.size());
        for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
            std::memcpy(rec.data(), &mesh.positions[3 * v], 12);
            std::size_t p = 12;
            if (normals) std::memcpy(rec.data() + p, &mesh.normals[3 * v], 12), p += 12;
            if (levels) rec[p++] = static_cast<char>(mesh.vertex_level[v]);
            if (colours) level_colour(mesh.vertex_level[v], rec.data() + p), p += 3;
            for (const auto& a : mesh.attributes) {
                std::memcpy(rec.data() + p, &a.values[v * a.components], 4 * std::size_t(a.components));
                p += 4 * std::size_t(a.components);
            }
            out.write(rec.data(), rec.size());
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

/// Vertices (`v`), normals (`vn`, one per vertex, same index) and faces (`f a b c`, or `f a//a ...`
/// with normals).
void write_obj(AtomicWriter& out, const Mesh& mesh) {
    std::string s = "# trilevel surface\n";
    const bool normals = !mesh.normals.empty();
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
        s += "v";
        for (int k = 0; k < 3; ++k) { s += ' '; append_float(s, mesh.positions[3 * v + k]); }
        s += '\n';
        if (normals) {
            s += "vn";
            for (int k = 0; k < 3; ++k) { s += ' '; append_float(s, mesh.normals[3 * v + k]); }
            s += '\n';
        }
        if (s.size() > (1 << 20)) { out.write(s); s.clear(); }
    }
    for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
        s += "f";
        for (int k = 0; k < 3; ++k) {
            const std::string i = std::to_string(std::uint64_t(mesh.triangles[3 * t + k]) + 1);
            s += ' ';
            s += i;
            if (normals) { s += "//"; s += i; }
        }
        s += '\n';
        if (s.size() > (1 << 20)) { out.write(s); s.clear(); }
    }
    out.write(s);
}

void write_vtk(AtomicWriter& out, const std::string& path, const Mesh& mesh) {
    const std::size_t nv = mesh.vertex_count(), nt = mesh.triangle_count();
    if (4 * nt > 0x7fffffff) fail(path, "too many triangles for a legacy VTK file; write .ply");
    for (const auto& a : mesh.attributes)
        if (a.name == "Normals" && !mesh.normals.empty())
            fail(path, "vertex attribute 'Normals' collides with the normals of a VTK file");
    // UNSTRUCTURED_GRID of triangles (cell type 5), not POLYDATA: every legacy reader takes it,
    // meshio's included (it reads no POLYDATA and no NORMALS section, hence VECTORS Normals).
    out.write("# vtk DataFile Version 4.2\ntrilevel surface\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS " + std::to_string(nv) + " float\n");
    write_floats(out, mesh.positions.data(), mesh.positions.size(), true);
    out.write("\nCELLS " + std::to_string(nt) + " " + std::to_string(4 * nt) + "\n");
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
    out.write("\nCELL_TYPES " + std::to_string(nt) + "\n");
    for (std::size_t t = 0; t < nt;) {
        const std::size_t m = std::min(nt - t, chunk.size() / 4);
        for (std::size_t k = 0; k < m; ++k) store<std::int32_t>(chunk.data() + 4 * k, 5, true);  // VTK_TRIANGLE
        out.write(chunk.data(), 4 * m);
        t += m;
    }
    out.write("\n");
    if (mesh.vertex_level.empty() && mesh.normals.empty() && mesh.attributes.empty()) return;
    out.write("POINT_DATA " + std::to_string(nv) + "\n");
    if (!mesh.vertex_level.empty()) {
        out.write("SCALARS level unsigned_char 1\nLOOKUP_TABLE default\n");
        out.write(mesh.vertex_level.data(), nv);
        out.write("\n");
    }
    if (!mesh.normals.empty()) {
        out.write("VECTORS Normals float\n");
        write_floats(out, mesh.normals.data(), mesh.normals.size(), true);
        out.write("\n");
    }
    for (const auto& a : mesh.attributes) {
        out.write(a.components == 1 ? "SCALARS " + a.name + " float 1\nLOOKUP_TABLE default\n" : "VECTORS " + a.name + " float\n");
        write_floats(out, a.values.data(), a.values.size(), true);
        out.write("\n");
    }
}

/// Base64 (RFC 4648, padded) of `n` bytes, appended to `out`.
void append_base64(std::string& out, const unsigned char* p, std::size_t n) {
    static const char table[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    out.reserve(out.size() + (n + 2) / 3 * 4);
    std::size_t i = 0;
    for (; i + 3 <= n; i += 3) {
        const std::uint32_t v = (std::uint32_t(p[i]) << 16) | (std::uint32_t(p[i + 1]) << 8) | p[i + 2];
        for (int k = 3; k >= 0; --k) out += table[(v >> (6 * k)) & 63];
    }
    if (i < n) {
        const std::uint32_t v = (std::uint32_t(p[i]) << 16) | (i + 1 < n ? std::uint32_t(p[i + 1]) << 8 : 0);
        out += table[(v >> 18) & 63];
        out += table[(v >> 12) & 63];
        out += i + 1 < n ? table[(v >> 6) & 63] : '=';
        out += '=';
    }
}

/// One DataArray in VTK's compressed inline form (format="binary", header_type UInt64,
/// vtkZLibDataCompressor): the base64 of the header [blocks, block size, last block size,
/// compressed size of each block], then the base64 of the compressed blocks, encoded apart as
/// VTK writes and reads them. Blocks of 1 MiB compressed at zlib's fastest level: the default
/// level takes several times as long for a few percent fewer bytes (bench/RESULTS-implementation.md).
void write_xml_array(AtomicWriter& out, const std::string& path, const std::string& attributes, const void* data,
                     std::size_t bytes) {
    constexpr std::size_t kBlock = std::size_t(1) << 20;
    const std::size_t blocks = (bytes + kBlock - 1) / kBlock;
    std::vector<std::uint64_t> header = {blocks, kBlock, blocks == 0 ? 0 : bytes - (blocks - 1) * kBlock};
    std::string body;
    std::vector<unsigned char> packed(compressBound(kBlock));
    const auto* in = static_cast<const unsigned char*>(data);
    for (std::size_t b = 0; b < blocks; ++b) {
        const std::size_t n = std::min(kBlock, bytes - b * kBlock);
        uLongf size = static_cast<uLongf>(packed.size());
        if (compress2(packed.data(), &size, in + b * kBlock, static_cast<uLong>(n), Z_BEST_SPEED) != Z_OK)
            fail(path, "zlib could not compress a data array");
        header.push_back(size);
        body.append(reinterpret_cast<const char*>(packed.data()), size);
    }
    std::string text = "        <DataArray " + attributes + " format=\"binary\">\n          ";
    append_base64(text, reinterpret_cast<const unsigned char*>(header.data()), header.size() * sizeof(std::uint64_t));
    append_base64(text, reinterpret_cast<const unsigned char*>(body.data()), body.size());
    text += "\n        </DataArray>\n";
    out.write(text);
}

/// `name` with the five characters XML reserves escaped, for an attribute value.
std::string xml_escaped(const std::string& name) {
    std::string out;
    for (char c : name) {
        if (c == '&') out += "&amp;";
        else if (c == '<') out += "&lt;";
        else if (c == '>') out += "&gt;";
        else if (c == '"') out += "&quot;";
        else if (c == '\'') out += "&apos;";
        else out += c;
    }
    return out;
}

/// VTK XML (header_type UInt64, little-endian: the byte order of every platform we build on,
/// checked below): PolyData with the triangles as Polys (`poly`), else an UnstructuredGrid of
/// triangle cells (VTK_TRIANGLE = 5; meshio reads this one, it has no PolyData reader). Point data:
/// `level` (UInt8, the active scalars), `Normals` (the active normals), then the attributes as
/// Float32 arrays of 1 or 3 components under their own names.
void write_vtk_xml(AtomicWriter& out, const std::string& path, const Mesh& mesh, bool poly) {
    static_assert(sizeof(std::uint64_t) == 8 && sizeof(float) == 4);
    const std::uint16_t probe = 1;
    if (*reinterpret_cast<const unsigned char*>(&probe) != 1) fail(path, "VTK XML output needs a little-endian host");
    const std::size_t nv = mesh.vertex_count(), nt = mesh.triangle_count();
    for (const auto& a : mesh.attributes)
        if (a.name == "Normals" && !mesh.normals.empty())
            fail(path, "vertex attribute 'Normals' collides with the normals of a VTK XML file");
    const std::string type = poly ? "PolyData" : "UnstructuredGrid";
    std::string head = "<?xml version=\"1.0\"?>\n<VTKFile type=\"" + type +
                       "\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\" "
                       "compressor=\"vtkZLibDataCompressor\">\n  <" + type + ">\n    <Piece NumberOfPoints=\"" +
                       std::to_string(nv) + "\" " +
                       (poly ? "NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\""
                             : "NumberOfCells=\"") + std::to_string(nt) + "\">\n      <PointData";
    if (!mesh.vertex_level.empty()) head += " Scalars=\"level\"";
    if (!mesh.normals.empty()) head += " Normals=\"Normals\"";
    head += ">\n";
    out.write(head);
    if (!mesh.vertex_level.empty())
        write_xml_array(out, path, "type=\"UInt8\" Name=\"level\"", mesh.vertex_level.data(), nv);
    if (!mesh.normals.empty())
        write_xml_array(out, path, "type=\"Float32\" Name=\"Normals\" NumberOfComponents=\"3\"", mesh.normals.data(),
                        4 * mesh.normals.size());
    for (const auto& a : mesh.attributes)  // NumberOfComponents only for vectors, as VTK writes them
        write_xml_array(out, path, "type=\"Float32\" Name=\"" + xml_escaped(a.name) + "\"" +
                                       (a.components == 3 ? " NumberOfComponents=\"3\"" : ""),
                        a.values.data(), 4 * a.values.size());
    out.write("      </PointData>\n      <Points>\n");
    write_xml_array(out, path, "type=\"Float32\" Name=\"Points\" NumberOfComponents=\"3\"", mesh.positions.data(),
                    4 * mesh.positions.size());
    out.write(poly ? "      </Points>\n      <Polys>\n" : "      </Points>\n      <Cells>\n");
    std::vector<std::int64_t> ints(mesh.triangles.begin(), mesh.triangles.end());
    write_xml_array(out, path, "type=\"Int64\" Name=\"connectivity\"", ints.data(), 8 * ints.size());
    ints.resize(nt);
    for (std::size_t t = 0; t < nt; ++t) ints[t] = std::int64_t(3 * (t + 1));
    write_xml_array(out, path, "type=\"Int64\" Name=\"offsets\"", ints.data(), 8 * ints.size());
    if (!poly) {
        const std::vector<std::uint8_t> types(nt, 5);
        write_xml_array(out, path, "type=\"UInt8\" Name=\"types\"", types.data(), nt);
    }
    out.write(poly ? "      </Polys>\n    </Piece>\n  </PolyData>\n</VTKFile>\n"
                   : "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
}

}  // namespace
}  // namespace io

void check_mesh_extension(const std::string& path) {
    const std::string ext = io::extension_of(path);
    if (ext != "ply" && ext != "obj" && ext != "vtk" && ext != "vtp" && ext != "vtu")
        io::fail(path, "unknown mesh output extension '" + ext + "', expected .ply, .obj, .vtk, .vtp or .vtu");
}

void write_mesh(const std::string& path, const Mesh& mesh, const MeshWriteOptions& options) {
    using namespace io;
    check_mesh_extension(path);
    const std::string ext = extension_of(path);
    check_mesh(path, mesh);
    AtomicWriter out(path);
    if (ext == "ply") write_ply(out, path, mesh, options);
    else if (ext == "obj") write_obj(out, mesh);
    else if (ext == "vtk") write_vtk(out, path, mesh);
    else write_vtk_xml(out, path, mesh, ext == "vtp");
    out.commit();
}

}  // namespace trilevel
