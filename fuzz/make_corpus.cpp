// Writes the seed corpora of the fuzz targets: small valid files of every format and encoding the
// readers accept, made with trilevel's own writers and scene generator where they cover the case
// and built by hand where they do not (VTU encodings, ASCII and big-endian variants, BGEO), the
// VTU, BGEO and PLY ones with the reader tests' generators (tests/io_test_files.hpp).
//   trilevel_fuzz_corpus OUTDIR   ->  OUTDIR/corpus-{vtk,vtu,bgeo,ply,xyz,mesh}/
// Seeds stay small (a few to a few hundred particles) so that each run of a target is fast.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "../tests/io_test_files.hpp"
#include "trilevel/io.hpp"

namespace fs = std::filesystem;
using trilevel::Mesh;
using trilevel::ParticleSet;
using trilevel::test::bgeo_file;
using trilevel::test::gzip;
using trilevel::test::ply_file;
using trilevel::test::TestAttribute;
using trilevel::test::vtu_data_array;
using trilevel::test::VtuVariant;

namespace {

fs::path g_out;

fs::path dir(const std::string& target) {
    const fs::path d = g_out / ("corpus-" + target);
    fs::create_directories(d);
    return d;
}

void put(const std::string& target, const std::string& name, const std::string& bytes) {
    std::ofstream f(dir(target) / name, std::ios::binary);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!f) throw std::runtime_error("cannot write " + (dir(target) / name).string());
}

template <class T>
std::string bytes_of(T v, bool big) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big) std::reverse(b, b + sizeof(T));
    return std::string(b, sizeof(T));
}

std::string num_text(double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.9g", v);
    return b;
}

/// The first n particles of a generated scene.
std::vector<float> scene_points(const std::string& scene, std::size_t n) {
    ParticleSet s = trilevel::generate_scene(scene, 0.05f, 7);
    s.positions.resize(std::min(s.positions.size(), 3 * n));
    return s.positions;
}

/// Writes through trilevel's own writer and files the result under `target`.
void put_written(const std::string& target, const std::string& name, const ParticleSet& set) {
    const fs::path tmp = dir(target) / name;
    trilevel::write_particles(tmp.string(), set);
}

// ---- legacy VTK ---------------------------------------------------------------------------------

std::string vtk_text_values(const std::vector<float>& v) {
    std::string s;
    for (std::size_t i = 0; i < v.size(); ++i) s += num_text(v[i]) + (i % 9 == 8 ? "\n" : " ");
    return s + "\n";
}

/// Per-particle attribute values of the seeds: density (1 component) and velocity (3).
std::vector<float> densities(std::size_t n) {
    std::vector<float> d(n);
    for (std::size_t i = 0; i < n; ++i) d[i] = 1000.0f + static_cast<float>(i);
    return d;
}
std::vector<float> velocities(std::size_t n) {
    std::vector<float> v(3 * n);
    for (std::size_t i = 0; i < 3 * n; ++i) v[i] = 0.25f * static_cast<float>(i % 7) - 0.5f;
    return v;
}

/// POINT_DATA with density (SCALARS) and velocity (VECTORS, or a FIELD array), ASCII or binary.
std::string vtk_point_data(std::size_t n, bool binary, bool as_field) {
    auto values = [&](const std::vector<float>& v) {
        if (!binary) return vtk_text_values(v);
        std::string b;
        for (float x : v) b += bytes_of(x, true);
        return b + "\n";
    };
    const std::string count = std::to_string(n);
    std::string s = "POINT_DATA " + count + "\nSCALARS density float 1\nLOOKUP_TABLE default\n" + values(densities(n));
    if (as_field) s += "FIELD FieldData 1\nvelocity 3 " + count + " float\n" + values(velocities(n));
    else s += "VECTORS velocity float\n" + values(velocities(n));
    return s;
}

void vtk_seeds(const std::vector<float>& pts) {
    ParticleSet set;
    set.positions = pts;
    put_written("vtk", "written-binary.vtk", set);
    const std::string n = std::to_string(pts.size() / 3);
    std::string bin_f, bin_d;
    for (float p : pts) { bin_f += bytes_of(p, true); bin_d += bytes_of(double(p), true); }
    put("vtk", "binary-double-polydata.vtk",
        "# vtk DataFile Version 4.2\nparticles\nBINARY\nDATASET POLYDATA\nPOINTS " + n + " double\n" + bin_d + "\nVERTICES 0 0\n" + vtk_point_data(pts.size() / 3, true, true));
    put("vtk", "ascii-float-field.vtk",
        "# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET UNSTRUCTURED_GRID\nFIELD FieldData 2\ntime 1 1 double\n0.25\n"
        "cycle 1 1 int\n7\nPOINTS " + n + " float\n" + vtk_text_values(pts) +
        "CELLS 3 2\nOFFSETS vtktypeint64\n0 1 2\nCONNECTIVITY vtktypeint64\n0 1\nCELL_TYPES 2\n1 1\n" +
        vtk_point_data(pts.size() / 3, false, false));
    put("vtk", "ascii-double-structured.vtk",
        "# vtk DataFile Version 3.0\ngrid\nascii\nDATASET STRUCTURED_GRID\nDIMENSIONS " + n + " 1 1\nPOINTS " + n + " double\n" +
        vtk_text_values(pts) + "POINT_DATA " + n + "\nSCALARS density float 1\nLOOKUP_TABLE default\n");
    put("vtk", "binary-metadata-field.vtk",
        "# vtk DataFile Version 5.1\nx\nBINARY\nDATASET UNSTRUCTURED_GRID\nFIELD f 1\nid 1 2 int\n" + bytes_of(std::int32_t(1), true) +
        bytes_of(std::int32_t(2), true) + "\nMETADATA\nINFORMATION 0\n\nPOINTS " + n + " float\n" + bin_f + "\n" +
        vtk_point_data(pts.size() / 3, true, false));
    std::string ints;
    for (std::size_t i = 0; i < pts.size(); ++i) ints += std::to_string(int(pts[i] * 100)) + " ";
    put("vtk", "ascii-int.vtk", "# vtk DataFile Version 2.0\nints\nASCII\nDATASET POLYDATA\nPOINTS " + n + " int\n" + ints + "\n");
}

// ---- VTU ----------------------------------------------------------------------------------------

/// A VTU file holding pts in two pieces, with density (ascii) and velocity (stored like the
/// points) point data, stored as the variant says.
std::string two_piece_vtu(const std::vector<float>& pts, const VtuVariant& v) {
    const std::size_t half = pts.size() / 6 * 3;
    const std::vector<float> parts[2] = {{pts.begin(), pts.begin() + half}, {pts.begin() + half, pts.end()}};
    std::string pieces, appended;
    for (const auto& part : parts) {
        const std::size_t n = part.size() / 3;
        pieces += "<Piece NumberOfPoints=\"" + std::to_string(n) + "\" NumberOfCells=\"0\">\n<PointData>\n"
                  "<DataArray type=\"Float32\" Name=\"density\" format=\"ascii\">" + vtk_text_values(densities(n)) + "</DataArray>\n" +
                  vtu_data_array("velocity", 3, velocities(n), v, appended) + "\n</PointData>\n<Points>\n" +
                  vtu_data_array("Points", 3, part, v, appended) + "\n</Points>\n</Piece>\n";
    }
    std::string s = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"" +
                    std::string(v.big ? "BigEndian" : "LittleEndian") + "\" header_type=\"" + (v.u32 ? "UInt32" : "UInt64") + "\"" +
                    (v.zlib ? " compressor=\"vtkZLibDataCompressor\"" : "") + ">\n<UnstructuredGrid>\n" + pieces + "</UnstructuredGrid>\n";
    if (v.format == "appended")
        s += std::string("<AppendedData encoding=\"") + (v.base64_appended ? "base64" : "raw") + "\">\n _" + appended + "\n</AppendedData>\n";
    return s + "</VTKFile>\n";
}

void vtu_seeds(const std::vector<float>& pts) {
    const std::vector<VtuVariant> variants = {
        {"ascii", "ascii"},
        {"binary", "binary"},
        {"binary-joint", "binary", false, true},
        {"binary-zlib", "binary", true},
        {"binary-zlib-joint-u32", "binary", true, true, false, true},
        {"binary-zlib-big-f32", "binary", true, false, false, true, true, true},
        {"appended-raw", "appended"},
        {"appended-raw-u32-f32", "appended", false, false, false, true, false, true},
        {"appended-raw-big", "appended", false, false, false, false, true},
        {"appended-raw-zlib", "appended", true},
        {"appended-raw-zlib-u32-f32", "appended", true, false, false, true, false, true},
        {"appended-base64", "appended", false, false, true},
        {"appended-base64-f32", "appended", false, false, true, false, false, true},
        {"appended-base64-zlib", "appended", true, false, true},
        {"appended-base64-zlib-joint-big", "appended", true, true, true, false, true},
    };
    for (const auto& v : variants) put("vtu", v.name + ".vtu", two_piece_vtu(pts, v));
}

// ---- BGEO ---------------------------------------------------------------------------------------

void bgeo_seeds(const std::vector<float>& pts) {
    put("bgeo", "plain.bgeo", bgeo_file(pts, false));
    put("bgeo", "plain-attributes.bgeo", bgeo_file(pts, true));
    put("bgeo", "gzip.bgeo", gzip(bgeo_file(pts, false)));
    put("bgeo", "gzip-attributes.bgeo", gzip(bgeo_file(pts, true)));
    const std::string whole = bgeo_file(pts, true);  // two gzip members, as concatenated streams
    put("bgeo", "gzip-two-members.bgeo", gzip(whole.substr(0, 40)) + gzip(whole.substr(40)));
}

// ---- PLY ----------------------------------------------------------------------------------------

void ply_seeds(const std::vector<float>& pts) {
    // trilevel::test::ply_file: a leading element, extra and list vertex properties, shuffled x, y, z,
    // then density and velocity_x/_y/_z
    const std::vector<TestAttribute> attrs = {{"density", 1, densities(pts.size() / 3)}, {"velocity", 3, velocities(pts.size() / 3)}};
    ParticleSet set;
    set.positions = pts;
    put_written("ply", "written-binary-le.ply", set);
    put("ply", "ascii-float.ply", ply_file(pts, "ascii", false, attrs));
    put("ply", "ascii-double.ply", ply_file(pts, "ascii", true, attrs));
    put("ply", "binary-le-double.ply", ply_file(pts, "binary_little_endian", true, attrs));
    put("ply", "binary-be-float.ply", ply_file(pts, "binary_big_endian", false, attrs));
    put("ply", "binary-be-double.ply", ply_file(pts, "binary_big_endian", true, attrs));
    std::string ints = "ply\r\nformat binary_little_endian 1.0\r\nelement vertex 2\r\nproperty short x\r\nproperty int y\r\n"
                       "property uint8 z\r\nend_header\r\n";
    for (int i = 0; i < 2; ++i) ints += bytes_of(std::int16_t(-3 * i), false) + bytes_of(std::int32_t(70000), false) + bytes_of(std::uint8_t(9), false);
    put("ply", "binary-le-integers-crlf.ply", ints);
}

// ---- XYZ ----------------------------------------------------------------------------------------

void xyz_seeds(const std::vector<float>& pts) {
    ParticleSet set;
    set.positions = pts;
    put_written("xyz", "written.xyz", set);
    set.positions.resize(3);
    put_written("xyz", "one.xyz", set);
}

// ---- meshes -------------------------------------------------------------------------------------

/// A closed octahedron with levels 2 and 3 on alternate vertices.
Mesh octahedron() {
    Mesh m;
    m.positions = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    m.triangles = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    m.vertex_level = {2, 3, 2, 3, 2, 3};
    m.normals = m.positions;  // the unit vertex directions are the outward normals
    m.attributes.push_back({"density", 1, {1000, 1001, 1002, 1003, 1004, 1005}});
    m.attributes.push_back({"velocity", 3, velocities(6)});
    return m;
}

void mesh_seeds() {
    const Mesh m = octahedron();
    const fs::path d = dir("mesh");
    trilevel::write_mesh((d / "written-levels.ply").string(), m);
    trilevel::write_mesh((d / "written-colours.ply").string(), m, {true, true});
    Mesh plain = m;
    plain.normals.clear();
    plain.attributes.clear();
    trilevel::write_mesh((d / "written-plain.ply").string(), plain, {false, false});
    trilevel::write_mesh((d / "written-plain.vtk").string(), plain);
    trilevel::write_mesh((d / "written.obj").string(), m);
    trilevel::write_mesh((d / "written.vtk").string(), m);
    std::string ply = "ply\nformat ascii 1.0\nelement vertex 6\nproperty double x\nproperty double y\nproperty double z\n"
                      "property uchar level\nelement edge 1\nproperty int a\nproperty int b\nelement face 2\n"
                      "property list uchar int vertex_index\nproperty uchar flags\nend_header\n";
    for (std::size_t v = 0; v < 6; ++v)
        ply += num_text(m.positions[3 * v]) + " " + num_text(m.positions[3 * v + 1]) + " " + num_text(m.positions[3 * v + 2]) + " " +
               std::to_string(m.vertex_level[v]) + "\n";
    ply += "0 1\n4 0 2 1 3 7\n3 0 4 5 0\n";  // a quad (fan-triangulated) and a triangle
    put("mesh", "ascii-quad.ply", ply);
    put("mesh", "corners.obj",
        "# corners with texture and normal indices, a negative index, a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
        "f 1/1/1 2/1/1 3/1/1\nf 1//1 3//1 4//1\nf -4 -3 -2 -1\ng group\ns off\n");
    put("mesh", "ascii-polydata.vtk",
        "# vtk DataFile Version 3.0\nmesh\nASCII\nDATASET POLYDATA\nPOINTS 4 float\n0 0 0 1 0 0 1 1 0 0 1 0\n"
        "POLYGONS 2 9\n3 0 1 2\n4 0 1 2 3\nPOINT_DATA 4\nSCALARS level unsigned_char 1\nLOOKUP_TABLE default\n2 3 2 3\n");
}

/// Every seed must be read without error, or the fuzzer starts from rejections only.
void check_seeds() {
    for (const auto& target : {"vtk", "vtu", "bgeo", "ply", "xyz", "mesh"}) {
        std::size_t files = 0, with_attributes = 0;
        for (const auto& e : fs::directory_iterator(dir(target))) {
            const std::string f = e.path().string();
            const bool mesh = std::string(target) == "mesh";
            const std::size_t n = mesh ? trilevel::read_mesh(f).vertex_count() : trilevel::read_particles(f).size();
            if (n == 0) throw std::runtime_error(f + ": seed holds no points");
            ++files;
            try {  // the fuzz targets ask for these two: some seeds must have them
                if (mesh ? !trilevel::read_mesh(f).attributes.empty()
                         : trilevel::read_particles(f, {{"velocity", "density"}, false}).attributes.size() == 2)
                    ++with_attributes;
            } catch (const trilevel::Error&) {
            }
        }
        std::cout << "corpus-" << target << ": " << files << " seeds, " << with_attributes << " with velocity and density\n";
        if (with_attributes == 0 && std::string(target) != "xyz")
            throw std::runtime_error(std::string("no seed of corpus-") + target + " holds velocity and density");
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::cerr << "usage: " << argv[0] << " OUTDIR   (writes OUTDIR/corpus-<target>/)\n";
        return 2;
    }
    try {
        g_out = argv[1];
        const auto few = scene_points("sphere", 16), more = scene_points("dam-break", 200);
        vtk_seeds(few);
        vtu_seeds(few);
        bgeo_seeds(few);
        ply_seeds(few);
        xyz_seeds(more);
        mesh_seeds();
        // one larger file per particle format: readers take other paths for bigger arrays
        ParticleSet set;
        set.positions = more;
        put_written("vtk", "written-200.vtk", set);
        put_written("ply", "written-200.ply", set);
        put("vtu", "appended-raw-zlib-200.vtu", two_piece_vtu(more, {"", "appended", true}));
        put("bgeo", "gzip-200.bgeo", gzip(bgeo_file(more, true)));
        check_seeds();
    } catch (const std::exception& e) {
        std::cerr << "trilevel_fuzz_corpus: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
