// Particle files written by the reader tests themselves (no binary blobs in the repository):
// every format and encoding, with or without point attributes, byte by byte. Catch-free: the
// fuzz seed corpus generator (fuzz/make_corpus.cpp) builds its VTU, BGEO and PLY seeds with it.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include <zlib.h>

#include "encodings.hpp"

namespace trilevel::test {

inline void write_bytes(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// A few particles with awkward values: exact round trips must keep every bit.
inline std::vector<float> sample_points() {
    return {0.0f, -0.0f, 1.0f, 0.1f, -2.5e-3f, 3.4e38f, 1e-40f, 123456.789f, -7.0f, 0.33333334f, 42.0f, -1e-7f};
}

template <class T>
std::string be_bytes(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    std::reverse(b, b + sizeof(T));
    return std::string(b, sizeof(T));
}

template <class T>
std::string le_bytes(T v) {
    return std::string(reinterpret_cast<const char*>(&v), sizeof(T));
}

/// A point attribute as a test writes it.
struct TestAttribute {
    std::string name;
    int components = 1;
    std::vector<float> values;
};

/// n particles' worth of a 1- or 3-component attribute with distinct, exactly representable values.
inline TestAttribute test_attribute(const std::string& name, int components, std::size_t n, float base) {
    TestAttribute a{name, components, {}};
    for (std::size_t i = 0; i < n * components; ++i) a.values.push_back(base + 0.25f * float(i) - (i % 2 ? 3.0f : 0.0f));
    return a;
}

struct VtuVariant {
    std::string name;
    std::string format;  // ascii, binary, appended
    bool zlib = false, joint = false, base64_appended = false, u32 = false, big = false, f32 = false;
};

inline std::vector<VtuVariant> vtu_variants() {
    return {
        {"ascii", "ascii"},
        {"inline base64", "binary"},
        {"inline base64 joint", "binary", false, true},
        {"inline base64 zlib", "binary", true},
        {"inline base64 zlib u32", "binary", true, false, false, true},
        {"appended raw", "appended"},
        {"appended raw u32", "appended", false, false, false, true},
        {"appended base64", "appended", false, false, true},
        {"appended raw zlib", "appended", true},
        {"appended base64 zlib", "appended", true, false, true},
        {"appended raw big endian", "appended", false, false, false, false, true},
        {"inline base64 zlib big endian f32", "binary", true, false, false, true, true, true},
        {"appended base64 f32", "appended", false, false, true, false, false, true},
    };
}

/// One array's header + payload as VTK writes it (blocks of 16 bytes when compressed).
inline std::string vtu_encoded_block(const std::string& raw, const VtuVariant& v, std::string* header_out = nullptr,
                                     std::string* payload_out = nullptr) {
    auto word = [&](std::uint64_t w) {
        if (v.u32) return v.big ? be_bytes(std::uint32_t(w)) : le_bytes(std::uint32_t(w));
        return v.big ? be_bytes(w) : le_bytes(w);
    };
    std::string header, payload;
    if (v.zlib) {
        const std::size_t bs = 16, nb = (raw.size() + bs - 1) / bs;
        std::vector<std::string> blocks;
        for (std::size_t b = 0; b < nb; ++b) blocks.push_back(zcompress(raw.substr(b * bs, bs)));
        header = word(nb) + word(bs) + word(raw.size() - (nb - 1) * bs);
        for (auto& b : blocks) { header += word(b.size()); payload += b; }
    } else {
        header = word(raw.size());
        payload = raw;
    }
    if (header_out) *header_out = header;
    if (payload_out) *payload_out = payload;
    return header + payload;
}

/// A DataArray element holding `values`, stored as the variant says; appended data is added to
/// `appended` (its offset goes into the tag).
inline std::string vtu_data_array(const std::string& name, int components, const std::vector<float>& values,
                                  const VtuVariant& v, std::string& appended) {
    std::string raw;
    for (float p : values) {
        if (v.f32) raw += v.big ? be_bytes(p) : le_bytes(p);
        else raw += v.big ? be_bytes(double(p)) : le_bytes(double(p));
    }
    std::string header, payload, text;
    vtu_encoded_block(raw, v, &header, &payload);
    const std::string offset = std::to_string(appended.size());
    if (v.format == "ascii") {
        char buf[64];
        for (float p : values) { std::snprintf(buf, sizeof buf, "%.9g ", double(p)); text += buf; }
    } else {
        const std::string enc = v.joint ? b64(header + payload) : b64(header) + b64(payload);
        if (v.format == "binary") text = "\n  " + enc + "\n";
        else appended += v.base64_appended ? enc : header + payload;
    }
    return "<DataArray type=\"" + std::string(v.f32 ? "Float32" : "Float64") + "\" Name=\"" + name + "\" NumberOfComponents=\"" +
           std::to_string(components) + "\" format=\"" + v.format + "\"" +
           (v.format == "appended" ? " offset=\"" + offset + "\"/>" : ">" + text + "</DataArray>");
}

/// A VTU file holding pts (and attributes as PointData), stored as the variant says. Without
/// attributes, PointData holds an ascii 'density' array the position reader must skip.
inline std::string make_vtu(const std::vector<float>& pts, const VtuVariant& v, const std::vector<TestAttribute>& attrs = {}) {
    std::string appended;
    const std::string points = vtu_data_array("Points", 3, pts, v, appended);
    std::string point_data = "<DataArray type=\"Float32\" Name=\"density\" format=\"ascii\">1 2 3 4</DataArray>\n";
    if (!attrs.empty()) point_data.clear();
    for (const auto& a : attrs) point_data += vtu_data_array(a.name, a.components, a.values, v, appended) + "\n";
    std::string s = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"" +
                    std::string(v.big ? "BigEndian" : "LittleEndian") + "\" header_type=\"" + (v.u32 ? "UInt32" : "UInt64") +
                    "\"" + (v.zlib ? " compressor=\"vtkZLibDataCompressor\"" : "") + ">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"" +
                    std::to_string(pts.size() / 3) + "\" NumberOfCells=\"0\">\n<PointData>\n" + point_data +
                    "</PointData>\n<Points>\n" + points + "\n</Points>\n</Piece>\n</UnstructuredGrid>\n";
    if (v.format == "appended")
        s += std::string("<AppendedData encoding=\"") + (v.base64_appended ? "base64" : "raw") + "\">\n _" + appended + "\n</AppendedData>\n";
    return s + "</VTKFile>\n";
}

/// BGEO v5; with attributes: id (int), velocity (vector) = (i, -i/2, 2 + i), kind (indexed
/// string), density (float) = 1000 + i/4, in that order.
inline std::string bgeo_file(const std::vector<float>& pts, bool with_attributes) {
    auto i32 = [](std::int32_t v) { return be_bytes(v); };
    auto u16 = [](std::uint16_t v) { return be_bytes(v); };
    const std::int32_t n = static_cast<std::int32_t>(pts.size() / 3);
    std::string s = "BgeoV" + i32(5) + i32(n) + i32(0) + i32(0) + i32(0) + i32(with_attributes ? 4 : 0) + i32(0) + i32(0) + i32(0);
    if (with_attributes) {
        s += u16(2) + "id" + u16(1) + i32(1) + i32(0);                                     // int
        s += u16(8) + "velocity" + u16(3) + i32(5) + i32(0) + i32(0) + i32(0);             // vector
        s += u16(4) + "kind" + u16(1) + i32(4) + i32(2) + u16(5) + "water" + u16(3) + "air";  // indexed string
        s += u16(7) + "density" + u16(1) + i32(0) + be_bytes(1000.0f);                     // float
    }
    for (std::int32_t i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) s += be_bytes(pts[3 * i + k]);
        s += be_bytes(1.0f);
        if (with_attributes)
            s += i32(i) + be_bytes(float(i)) + be_bytes(-0.5f * float(i)) + be_bytes(2.0f + float(i)) + i32(i % 2) +
                 be_bytes(1000.0f + 0.25f * float(i));
    }
    return s + std::string("\x00\xff", 2);
}

inline std::string vtk_binary(const std::vector<float>& pts, const std::string& version, const std::string& dataset, bool as_double) {
    std::string s = "# vtk DataFile Version " + version + "\ntest\nBINARY\nDATASET " + dataset + "\nPOINTS " +
                    std::to_string(pts.size() / 3) + (as_double ? " double\n" : " float\n");
    for (float p : pts) s += as_double ? be_bytes(double(p)) : be_bytes(p);
    return s + "\nVERTICES 0 0\n";
}

inline std::string vtk_ascii(const std::vector<float>& pts, const std::string& type) {
    std::string s = "# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET UNSTRUCTURED_GRID\n"
                    "FIELD FieldData 1\ntime 1 1 double\n0.25\nPOINTS " + std::to_string(pts.size() / 3) + " " + type + "\n";
    char buf[64];
    for (std::size_t i = 0; i < pts.size(); ++i) { std::snprintf(buf, sizeof buf, "%.9g%c", double(pts[i]), i % 9 == 8 ? '\n' : ' '); s += buf; }
    s += "\nCELLS 3 2\nOFFSETS vtktypeint64\n0 1 2\nCONNECTIVITY vtktypeint64\n0 1\nCELL_TYPES 2\n1 1\n";
    return s;
}

/// Legacy VTK with everything a SPlisHSPlasH/ParaView particle file carries after POINTS: one
/// vertex cell per particle (4.2: CELLS n 2n; 5.1: OFFSETS/CONNECTIVITY), CELL_TYPES, CELL_DATA,
/// then POINT_DATA with the attributes: the first as SCALARS (with LOOKUP_TABLE), 3-component
/// ones as VECTORS, the rest as FIELD arrays; texture coordinates and colour scalars to skip.
inline std::string vtk_with_data(const std::vector<float>& pts, const std::vector<TestAttribute>& attrs, bool binary, bool v5) {
    const std::size_t n = pts.size() / 3;
    std::string s = std::string("# vtk DataFile Version ") + (v5 ? "5.1" : "4.2") + "\nattributes\n" + (binary ? "BINARY" : "ASCII") +
                    "\nDATASET UNSTRUCTURED_GRID\nPOINTS " + std::to_string(n) + " float\n";
    auto f32 = [&](float v) {
        if (binary) return be_bytes(v);
        char b[64];
        std::snprintf(b, sizeof b, "%.9g ", double(v));
        return std::string(b);
    };
    auto i32 = [&](std::int32_t v) { return binary ? be_bytes(v) : std::to_string(v) + " "; };
    auto i64 = [&](std::int64_t v) { return binary ? be_bytes(v) : std::to_string(v) + " "; };
    for (float p : pts) s += f32(p);
    if (v5) {
        s += "\nCELLS " + std::to_string(n + 1) + " " + std::to_string(n) + "\nOFFSETS vtktypeint64\n";
        for (std::size_t i = 0; i <= n; ++i) s += i64(std::int64_t(i));
        s += "\nCONNECTIVITY vtktypeint64\n";
        for (std::size_t i = 0; i < n; ++i) s += i64(std::int64_t(i));
    } else {
        s += "\nCELLS " + std::to_string(n) + " " + std::to_string(2 * n) + "\n";
        for (std::size_t i = 0; i < n; ++i) s += i32(1) + i32(std::int32_t(i));
    }
    s += "\nCELL_TYPES " + std::to_string(n) + "\n";
    for (std::size_t i = 0; i < n; ++i) s += i32(1);
    s += "\nCELL_DATA " + std::to_string(n) + "\nSCALARS velocity float 1\nLOOKUP_TABLE default\n";  // a cell array: not a point attribute
    for (std::size_t i = 0; i < n; ++i) s += f32(-1.0f);
    s += "\nPOINT_DATA " + std::to_string(n) + "\nTEXTURE_COORDINATES uv 2 float\n";
    for (std::size_t i = 0; i < 2 * n; ++i) s += f32(0.5f);
    s += "\nCOLOR_SCALARS rgb 3\n";
    for (std::size_t i = 0; i < 3 * n; ++i) s += binary ? std::string(1, char(200)) : std::string("0.5 ");
    std::vector<const TestAttribute*> field;
    for (std::size_t a = 0; a < attrs.size(); ++a) {
        const TestAttribute& t = attrs[a];
        if (a == 0) s += "\nSCALARS " + t.name + " float " + std::to_string(t.components) + "\nLOOKUP_TABLE default\n";
        else if (t.components == 3 && a == 1) s += "\nVECTORS " + t.name + " float\n";
        else { field.push_back(&t); continue; }
        for (float v : t.values) s += f32(v);
    }
    if (!field.empty()) {
        s += "\nFIELD FieldData " + std::to_string(field.size() + 1) + "\nother 1 2 float\n" + f32(1) + f32(2);
        for (const auto* t : field) {
            s += "\n" + t->name + " " + std::to_string(t->components) + " " + std::to_string(n) + " float\n";
            for (float v : t->values) s += f32(v);
        }
    }
    return s + "\n";
}

/// PLY with a camera element before the vertices, vertex properties flag, z, x, a list, y, and
/// the attributes: 1-component ones by name, 3-component ones as name_x, name_y, name_z.
inline std::string ply_file(const std::vector<float>& pts, const std::string& format, bool doubles,
                            const std::vector<TestAttribute>& attrs = {}) {
    const std::size_t n = pts.size() / 3;
    std::string s = "ply\nformat " + format + " 1.0\ncomment made by a test\nobj_info trilevel\nelement camera 1\nproperty float fov\nproperty list uchar int ids\n"
                    "element vertex " + std::to_string(n) + "\nproperty uchar flag\nproperty " + (doubles ? "double" : "float") +
                    " z\nproperty " + (doubles ? "double" : "float") + " x\nproperty list uchar float extra\nproperty " +
                    (doubles ? "double" : "float") + " y\n";
    for (const auto& a : attrs) {
        if (a.components == 1) s += "property float " + a.name + "\n";
        else for (const char* c : {"_x", "_y", "_z"}) s += "property float " + a.name + c + "\n";
    }
    s += "element face 0\nproperty list uchar int vertex_indices\nend_header\n";
    const bool ascii = format == "ascii", big = format == "binary_big_endian";
    auto num = [&](auto v) {
        if (ascii) { char b[64]; std::snprintf(b, sizeof b, "%.17g ", double(v)); return std::string(b); }
        return big ? be_bytes(v) : le_bytes(v);
    };
    s += num(45.0f) + num(std::uint8_t(2)) + num(std::int32_t(7)) + num(std::int32_t(8)) + (ascii ? "\n" : "");
    for (std::size_t i = 0; i < n; ++i) {
        const float x = pts[3 * i], y = pts[3 * i + 1], z = pts[3 * i + 2];
        s += num(std::uint8_t(1));
        s += doubles ? num(double(z)) + num(double(x)) : num(z) + num(x);
        s += num(std::uint8_t(i % 3));
        for (std::size_t k = 0; k < i % 3; ++k) s += num(0.5f);
        s += doubles ? num(double(y)) : num(y);
        for (const auto& a : attrs)
            for (int c = 0; c < a.components; ++c) s += num(a.values[i * a.components + c]);
        s += ascii ? "\n" : "";
    }
    return s;
}

}  // namespace trilevel::test
