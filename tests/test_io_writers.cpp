// Particle and mesh writers: bit-exact round trips through the readers, atomic writes.
#include <cmath>
#include <cstring>
#include <fstream>

#include "cli_test_support.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"

using trilevel::test::TempDir;
using trilevel::test::same_bits;

namespace {

trilevel::ParticleSet awkward_particles() {
    trilevel::ParticleSet p;
    p.positions = {0.0f, -0.0f, 1.0f, 0.1f, -2.5e-3f, 3.4e38f, 1e-40f, 123456.789f, -7.0f, 0.33333334f, 42.0f, -1e-7f};
    for (int i = 0; i < 3000; ++i) p.positions.push_back(std::sin(float(i)) * 1e3f + float(i) * 1e-3f);
    return p;
}

/// Two tetrahedra sharing nothing, with levels 2 and 3.
trilevel::Mesh small_mesh() {
    trilevel::Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 5.1f, 5.2f, 5.3f, 6.1f, 5, 5, 5, 6.7f, 5, 5, 5, 6.000001f};
    m.triangles = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3, 4, 6, 5, 4, 5, 7, 4, 7, 6, 5, 6, 7};
    m.vertex_level = {2, 2, 2, 2, 3, 3, 3, 2};
    m.triangle_kind.assign(8, trilevel::TriangleKind::Level2);
    return m;
}

std::vector<std::string> names_in(const std::filesystem::path& dir) {
    std::vector<std::string> out;
    for (const auto& e : std::filesystem::directory_iterator(dir)) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
}

}  // namespace

TEST_CASE("particle writers round-trip bit-exactly through the readers", "[io]") {
    TempDir tmp;
    const auto p = awkward_particles();
    for (const std::string ext : {"xyz", "ply", "vtk"}) {
        INFO(ext);
        const std::string f = tmp.file("p." + ext);
        trilevel::write_particles(f, p);
        REQUIRE(same_bits(trilevel::read_particles(f).positions, p.positions));
    }
    REQUIRE(names_in(tmp.path) == std::vector<std::string>{"p.ply", "p.vtk", "p.xyz"});  // no temporaries left
}

TEST_CASE("empty particle sets round-trip", "[io]") {
    TempDir tmp;
    for (const std::string ext : {"ply", "vtk"}) {
        const std::string f = tmp.file("e." + ext);
        trilevel::write_particles(f, {});
        REQUIRE(trilevel::read_particles(f).size() == 0);
    }
}

TEST_CASE("mesh writers round-trip positions, triangles and levels", "[io]") {
    TempDir tmp;
    const auto m = small_mesh();
    for (const std::string ext : {"ply", "obj", "vtk"}) {
        INFO(ext);
        const std::string f = tmp.file("m." + ext);
        trilevel::write_mesh(f, m);
        const auto r = trilevel::read_mesh(f);
        REQUIRE(same_bits(r.positions, m.positions));
        REQUIRE(r.triangles == m.triangles);
        if (ext != "obj") REQUIRE(r.vertex_level == m.vertex_level);
    }
    trilevel::MeshWriteOptions colour;
    colour.color_levels = true;
    trilevel::write_mesh(tmp.file("c.ply"), m, colour);
    const auto r = trilevel::read_mesh(tmp.file("c.ply"));
    REQUIRE(r.vertex_level == m.vertex_level);
    REQUIRE(same_bits(r.positions, m.positions));
    trilevel::MeshWriteOptions plain;
    plain.vertex_level = false;
    trilevel::write_mesh(tmp.file("p.ply"), m, plain);
    REQUIRE(trilevel::read_mesh(tmp.file("p.ply")).vertex_level.empty());
    REQUIRE(trilevel::read_mesh(tmp.file("p.ply")).triangles == m.triangles);
}

TEST_CASE("PLY mesh header declares level and colours as documented", "[io]") {
    TempDir tmp;
    trilevel::MeshWriteOptions o;
    o.color_levels = true;
    trilevel::write_mesh(tmp.file("c.ply"), small_mesh(), o);
    std::ifstream in(tmp.file("c.ply"), std::ios::binary);
    std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string head = all.substr(0, all.find("end_header"));
    CHECK(head.find("format binary_little_endian 1.0") != std::string::npos);
    CHECK(head.find("property uchar level\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n") != std::string::npos);
    CHECK(head.find("element face 8\nproperty list uchar uint vertex_indices") != std::string::npos);
    // first vertex: 12 bytes of position, level 2, then green
    const std::size_t body = all.find("end_header\n") + 11;
    CHECK(static_cast<unsigned char>(all[body + 12]) == 2);
    CHECK(static_cast<unsigned char>(all[body + 14]) == 170);
    CHECK(static_cast<unsigned char>(all[body + 13]) == 0);
}

TEST_CASE("read_mesh accepts ascii PLY and OBJ polygons with negative and slashed indices", "[io]") {
    TempDir tmp;
    std::ofstream(tmp.file("a.ply")) << "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                                        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                        "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
    auto a = trilevel::read_mesh(tmp.file("a.ply"));
    REQUIRE(a.triangles == std::vector<std::uint32_t>{0, 1, 2, 0, 2, 3});
    std::ofstream(tmp.file("q.obj")) << "v 0 0 0\nv 1 0 0\nvt 0 0\nv 1 1 0\nf 1/1 2/1 -1/1\n";
    REQUIRE(trilevel::read_mesh(tmp.file("q.obj")).triangles == std::vector<std::uint32_t>{0, 1, 2});
    std::ofstream(tmp.file("bad.obj")) << "v 0 0 0\nf 1 2 3\n";
    REQUIRE_THROWS_WITH(trilevel::read_mesh(tmp.file("bad.obj")), Catch::Contains("bad.obj") && Catch::Contains("line 2"));
}

TEST_CASE("read_mesh rejects non-finite normals and attributes, and VTK levels outside 0..255", "[io]") {
    TempDir tmp;
    const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                             "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                             "property float density\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    std::ofstream(tmp.file("ok.ply")) << head << "0 0 0 0 0 1 5\n1 0 0 0 0 1 5\n0 1 0 0 0 1 5\n3 0 1 2\n";
    REQUIRE(trilevel::read_mesh(tmp.file("ok.ply")).normals.size() == 9);
    std::ofstream(tmp.file("n.ply")) << head << "0 0 0 0 0 nan 5\n1 0 0 0 0 1 5\n0 1 0 0 0 1 5\n3 0 1 2\n";
    REQUIRE_THROWS_WITH(trilevel::read_mesh(tmp.file("n.ply")), Catch::Contains("n.ply") && Catch::Contains("normal is not finite"));
    std::ofstream(tmp.file("d.ply")) << head << "0 0 0 0 0 1 5\n1 0 0 0 0 1 inf\n0 1 0 0 0 1 5\n3 0 1 2\n";
    REQUIRE_THROWS_WITH(trilevel::read_mesh(tmp.file("d.ply")), Catch::Contains("attribute 'density'") && Catch::Contains("not finite"));
    std::ofstream(tmp.file("l.vtk")) << "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n"
                                        "0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 2\nPOINT_DATA 3\nSCALARS level int 1\n"
                                        "LOOKUP_TABLE default\n2 3 300\n";
    REQUIRE_THROWS_WITH(trilevel::read_mesh(tmp.file("l.vtk")), Catch::Contains("l.vtk") && Catch::Contains("vertex level 300 out of range"));
}

TEST_CASE("legacy .vtk meshes: an UNSTRUCTURED_GRID of triangles with VECTORS Normals, and POLYDATA still read", "[io]") {
    TempDir tmp;
    trilevel::Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    m.triangles = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    m.vertex_level = {2, 3, 2, 3};
    m.normals = {-1, -1, -1, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    trilevel::write_mesh(tmp.file("t.vtk"), m);
    const std::string text = trilevel::test::slurp(tmp.file("t.vtk"));
    CHECK(text.find("DATASET UNSTRUCTURED_GRID\n") != std::string::npos);  // what meshio's legacy reader takes
    CHECK(text.find("\nCELLS 4 16\n") != std::string::npos);
    CHECK(text.find("\nCELL_TYPES 4\n") != std::string::npos);
    CHECK(text.find("VECTORS Normals float\n") != std::string::npos);
    CHECK(text.find("POLYDATA") == std::string::npos);
    CHECK(text.find("NORMALS") == std::string::npos);
    const trilevel::Mesh back = trilevel::read_mesh(tmp.file("t.vtk"));
    CHECK(back.positions == m.positions);
    CHECK(back.triangles == m.triangles);
    CHECK(back.vertex_level == m.vertex_level);
    CHECK(back.normals == m.normals);
    CHECK(back.attributes.empty());
    // an attribute named Normals beside the normals has no place of its own
    trilevel::Mesh clash = m;
    clash.attributes.push_back({"Normals", 3, std::vector<float>(12, 0.0f)});
    REQUIRE_THROWS_WITH(trilevel::write_mesh(tmp.file("c.vtk"), clash), Catch::Contains("'Normals' collides"));
    // cells that are not polygons are refused by name; POLYDATA files of other writers still read
    std::ofstream(tmp.file("tet.vtk")) << "# vtk DataFile Version 4.2\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n"
                                          "0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n";
    REQUIRE_THROWS_WITH(trilevel::read_mesh(tmp.file("tet.vtk")), Catch::Contains("cell 0 has type 10, not a triangle, polygon or quad"));
    std::ofstream(tmp.file("p.vtk")) << "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n"
                                        "0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 2\nPOINT_DATA 3\nNORMALS n float\n0 0 1 0 0 1 0 0 1\n";
    const trilevel::Mesh poly = trilevel::read_mesh(tmp.file("p.vtk"));
    CHECK(poly.triangles == std::vector<std::uint32_t>{0, 1, 2});
    CHECK(poly.normals.size() == 9);
}

TEST_CASE("writes are atomic: clear errors, no partial or temporary files", "[io]") {
    TempDir tmp;
    const auto p = awkward_particles();
    const auto m = small_mesh();
    REQUIRE_THROWS_WITH(trilevel::write_particles(tmp.file("missing/p.ply"), p),
                        Catch::Contains("missing/p.ply") && Catch::Contains("does not exist"));
    REQUIRE_THROWS_WITH(trilevel::write_mesh(tmp.file("missing/m.ply"), m), Catch::Contains("does not exist"));
    REQUIRE_THROWS_WITH(trilevel::write_mesh(tmp.file("m.stl"), m), Catch::Contains("m.stl") && Catch::Contains("extension"));
    REQUIRE_THROWS_WITH(trilevel::write_particles(tmp.file("p.bgeo"), p), Catch::Contains("extension"));
    std::filesystem::create_directories(tmp.path / "dir.ply");
    REQUIRE_THROWS_WITH(trilevel::write_mesh(tmp.file("dir.ply"), m), Catch::Contains("is a directory"));
    auto nan = p;
    nan.positions[7] = NAN;
    REQUIRE_THROWS_WITH(trilevel::write_particles(tmp.file("nan.xyz"), nan), Catch::Contains("non-finite"));
    auto broken = m;
    broken.triangles[5] = 99;
    REQUIRE_THROWS_WITH(trilevel::write_mesh(tmp.file("broken.obj"), broken), Catch::Contains("references vertex 99"));
    REQUIRE(names_in(tmp.path) == std::vector<std::string>{"dir.ply"});

    // an existing file is replaced whole
    trilevel::write_particles(tmp.file("p.xyz"), p);
    trilevel::ParticleSet one;
    one.positions = {1, 2, 3};
    trilevel::write_particles(tmp.file("p.xyz"), one);
    REQUIRE(std::filesystem::file_size(tmp.path / "p.xyz") == 12);

    // through a symbolic link (relative, in another directory, and a link to that link): the file
    // it names is replaced and the links stay links
    std::filesystem::create_directories(tmp.path / "frames");
    std::filesystem::create_symlink("../p.xyz", tmp.path / "frames" / "latest.xyz");
    std::filesystem::create_symlink("frames/latest.xyz", tmp.path / "again.xyz");
    trilevel::write_particles(tmp.file("again.xyz"), p);
    CHECK(std::filesystem::is_symlink(tmp.path / "again.xyz"));
    CHECK(std::filesystem::is_symlink(tmp.path / "frames" / "latest.xyz"));
    CHECK(std::filesystem::file_size(tmp.path / "p.xyz") == p.positions.size() * sizeof(float));
    CHECK(names_in(tmp.path / "frames") == std::vector<std::string>{"latest.xyz"});  // no temporary left there
}

TEST_CASE("VTK XML meshes (.vtp, .vtu) round-trip points, levels, normals and attributes through the VTU reader", "[io]") {
    // 120 000 vertices: the points (1.44 MB) and the connectivity span more than one zlib block of 1 MiB.
    trilevel::Mesh m;
    const std::size_t nv = 120000;
    for (std::size_t v = 0; v < nv; ++v)
        for (int k = 0; k < 3; ++k) m.positions.push_back(std::sin(float(3 * v + k)) * 10.0f + float(k));
    for (std::size_t t = 0; t + 2 < nv; t += 2) m.triangles.insert(m.triangles.end(), {std::uint32_t(t), std::uint32_t(t + 1), std::uint32_t(t + 2)});
    m.triangle_kind.assign(m.triangle_count(), trilevel::TriangleKind::Level2);
    for (std::size_t v = 0; v < nv; ++v) m.vertex_level.push_back(v % 3 ? 2 : 3);
    for (std::size_t v = 0; v < nv; ++v) {
        const float a = float(v) * 0.001f;
        m.normals.insert(m.normals.end(), {std::cos(a), std::sin(a), 0.0f});
    }
    m.attributes.push_back({"density", 1, {}});
    m.attributes.push_back({"velocity", 3, {}});
    for (std::size_t v = 0; v < nv; ++v) m.attributes[0].values.push_back(1000.0f + float(v) * 1e-3f);
    for (std::size_t v = 0; v < 3 * nv; ++v) m.attributes[1].values.push_back(std::cos(float(v)) * 2.5f);

    TempDir tmp;
    trilevel::ReadOptions with_data;
    with_data.attributes = {"level", "Normals", "density", "velocity"};
    for (const std::string ext : {"vtu", "vtp"}) {
        INFO(ext);
        const std::string f = tmp.file("m." + ext);
        trilevel::write_mesh(f, m);
        std::ifstream in(f, std::ios::binary);
        const std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        const std::string triangles = std::to_string(m.triangle_count());
        if (ext == "vtu") {
            CHECK(all.find("<VTKFile type=\"UnstructuredGrid\"") != std::string::npos);
            CHECK(all.find("NumberOfPoints=\"120000\" NumberOfCells=\"" + triangles + "\"") != std::string::npos);
            CHECK(all.find("Name=\"types\"") != std::string::npos);
        } else {
            CHECK(all.find("<VTKFile type=\"PolyData\"") != std::string::npos);
            CHECK(all.find("NumberOfStrips=\"0\" NumberOfPolys=\"" + triangles + "\"") != std::string::npos);
            CHECK(all.find("<Polys>") != std::string::npos);
        }
        CHECK(all.find("<PointData Scalars=\"level\" Normals=\"Normals\">") != std::string::npos);
        // The particle reader takes the Points and PointData of any VTK XML piece: read the
        // PolyData under a .vtu name.
        const std::string as_vtu = tmp.file("read." + ext + ".vtu");
        std::filesystem::copy_file(f, as_vtu);
        const auto r = trilevel::read_particles(as_vtu, with_data);
        REQUIRE(same_bits(r.positions, m.positions));
        REQUIRE(r.attributes.size() == 4);
        std::vector<float> levels(m.vertex_level.begin(), m.vertex_level.end());
        CHECK((r.attributes[0].components == 1 && r.attributes[0].values == levels));
        CHECK((r.attributes[1].components == 3 && same_bits(r.attributes[1].values, m.normals)));
        CHECK((r.attributes[2].components == 1 && same_bits(r.attributes[2].values, m.attributes[0].values)));
        CHECK((r.attributes[3].components == 3 && same_bits(r.attributes[3].values, m.attributes[1].values)));
    }
    // Without levels, normals or attributes: the bare geometry, and no PointData attributes.
    trilevel::Mesh bare;
    bare.positions = m.positions;
    bare.triangles = m.triangles;
    trilevel::write_mesh(tmp.file("bare.vtu"), bare);
    REQUIRE(same_bits(trilevel::read_particles(tmp.file("bare.vtu")).positions, m.positions));
    // An attribute named like the normals' array is refused, and nothing is left behind.
    auto clash = m;
    clash.attributes[0].name = "Normals";
    REQUIRE_THROWS_WITH(trilevel::write_mesh(tmp.file("clash.vtp"), clash),
                        Catch::Contains("clash.vtp") && Catch::Contains("vertex attribute 'Normals' collides"));
    REQUIRE(!std::filesystem::exists(tmp.path / "clash.vtp"));
}
