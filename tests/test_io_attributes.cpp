// Point attributes (ReadOptions::attributes) and dropping of NaN/Inf particles
// (ReadOptions::drop_invalid): real frames and round trips through files the tests write.
#include <cmath>
#include <cstring>
#include <numeric>

#include "io_test_files.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"

using trilevel::ParticleSet;
using trilevel::ReadOptions;
using trilevel::read_particles;
using namespace trilevel::test;

namespace {

ReadOptions with_attributes(std::vector<std::string> names, bool drop = false) {
    ReadOptions o;
    o.attributes = std::move(names);
    o.drop_invalid = drop;
    return o;
}

const trilevel::ParticleAttribute& attribute(const ParticleSet& set, const std::string& name) {
    for (const auto& a : set.attributes)
        if (a.name == name) return a;
    FAIL("no attribute " << name);
    throw 0;
}

void require_attribute(const ParticleSet& set, const TestAttribute& expected) {
    INFO("attribute " << expected.name);
    const auto& a = attribute(set, expected.name);
    REQUIRE(a.components == expected.components);
    REQUIRE(a.values.size() == set.size() * static_cast<std::size_t>(a.components));
    REQUIRE(same_bits(a.values, expected.values));
}

/// The attributes a round trip carries: a scalar, a 3-vector and a second scalar.
std::vector<TestAttribute> round_trip_attributes(std::size_t n) {
    return {test_attribute("density", 1, n, 1000.0f), test_attribute("velocity", 3, n, -2.0f),
            test_attribute("pressure", 1, n, 0.125f)};
}

}  // namespace

// Expected values below were read by an independent numpy reader of the same files (it parses
// the headers and offsets by hand: struct + zlib + base64), not by this code:
// /usr/bin/python3 tests/attribute_oracle.py ../shared/data

TEST_CASE("attributes of real frames: VTK SCALARS id and FIELD velocity", "[io][attributes]") {
    TRILEVEL_REQUIRE_SHARED_DATA(dir);
    const std::string f = (dir / "double_dam_break_frame_26_4732_particles.vtk").string();
    const ParticleSet plain = read_particles(f);
    const ParticleSet set = read_particles(f, with_attributes({"velocity", "id"}));
    REQUIRE(set.size() == 4732);
    REQUIRE(same_bits(set.positions, plain.positions));  // asking for attributes changes no position
    REQUIRE(set.attributes.size() == 2);
    CHECK(set.attributes[0].name == "velocity");  // in request order
    const auto& v = attribute(set, "velocity");
    REQUIRE(v.components == 3);
    REQUIRE(v.values.size() == 3 * 4732);
    CHECK(v.values[0] == -0.024965405464172363f);
    CHECK(v.values[1] == -1.556547999382019f);
    CHECK(v.values[2] == 0.0321471244096756f);
    CHECK(v.values[3 * 1234 + 0] == -1.0653523206710815f);
    CHECK(v.values[3 * 4731 + 1] == -1.4293230772018433f);
    CHECK(v.values[3 * 4731 + 2] == 0.045446205884218216f);
    // unsigned_int ids: a permutation of 0..n-1, the first ones as stored
    const auto& id = attribute(set, "id");
    REQUIRE(id.components == 1);
    REQUIRE(id.values.size() == 4732);
    CHECK(id.values[0] == 2379.0f);
    CHECK(id.values[4] == 2444.0f);
    CHECK(id.values[4731] == 2196.0f);
    std::vector<float> sorted = id.values;
    std::sort(sorted.begin(), sorted.end());
    std::vector<float> iota(4732);
    std::iota(iota.begin(), iota.end(), 0.0f);
    CHECK(sorted == iota);
    // a name the file lacks: the error lists what it has
    REQUIRE_THROWS_WITH(read_particles(f, with_attributes({"pressure"})),
                        Catch::Contains("double_dam_break_frame_26_4732_particles.vtk: no point attribute 'pressure' (the file has: id, velocity)"));
    // the bunny frame's header says 7706 points: its FIELD velocity has as many tuples
    const auto bunny = read_particles((dir / "bunny_frame_14_7705_particles.vtk").string(), with_attributes({"velocity"}));
    CHECK(bunny.size() == 7706);
    CHECK(bunny.attributes.at(0).values.size() == 3 * 7706);
    // a frame with empty POINT_DATA
    REQUIRE_THROWS_WITH(read_particles((dir / "cube_2366_particles.vtk").string(), with_attributes({"velocity"})),
                        Catch::Contains("no point attribute 'velocity' (the file has none)"));
}

TEST_CASE("attributes of real frames: VTU appended zlib and appended base64 hold the same data", "[io][attributes]") {
    TRILEVEL_REQUIRE_SHARED_DATA(dir);
    const auto opts = with_attributes({"velocity", "density", "pressure", "index"});
    // raw appended, zlib blocks, UInt64 headers, PointData after Points
    const ParticleSet z = read_particles((dir / "fluid_250_particles.vtu").string(), opts);
    // base64 appended, uncompressed, PointData before Points, arrays with <InformationKey> children
    const ParticleSet b = read_particles((dir / "fluid_encoded_250_particles.vtu").string(), opts);
    for (const ParticleSet* set : {&z, &b}) {
        REQUIRE(set->size() == 250);
        REQUIRE(set->attributes.size() == 4);
        const auto& v = attribute(*set, "velocity");
        REQUIRE(v.components == 3);
        REQUIRE(v.values.size() == 750);
        CHECK(v.values[0] == 0.2653822600841522f);
        CHECK(v.values[1] == 0.11693106591701508f);
        CHECK(v.values[2] == -0.08800327777862549f);
        CHECK(v.values[747] == -1.5543169975280762f);
        CHECK(v.values[749] == -0.7278468012809753f);
        const auto& d = attribute(*set, "density");
        REQUIRE(d.values.size() == 250);
        CHECK(d.values[0] == 995.5487670898438f);
        CHECK(d.values[100] == 992.5761108398438f);
        CHECK(d.values[249] == 895.1729736328125f);
        const auto& index = attribute(*set, "index");  // Int64 1..250 in file order
        for (std::size_t i = 0; i < 250; ++i) REQUIRE(index.values[i] == float(i + 1));
    }
    REQUIRE(same_bits(z.positions, b.positions));
    for (std::size_t a = 0; a < 4; ++a) {
        INFO(z.attributes[a].name);
        REQUIRE(same_bits(z.attributes[a].values, b.attributes[a].values));
    }
    REQUIRE_THROWS_WITH(read_particles((dir / "fluid_250_particles.vtu").string(), with_attributes({"Points"})),
                        Catch::Contains("no point attribute 'Points' (the file has: velocity, pressure, density, index)"));
}

TEST_CASE("attributes of real frames: BGEO float density and vector velocity, int id", "[io][attributes]") {
    TRILEVEL_REQUIRE_SHARED_DATA(dir);
    const std::string f = (dir / "dam_break_frame_9_6859_particles.bgeo").string();
    const ParticleSet set = read_particles(f, with_attributes({"density", "velocity", "id"}));
    REQUIRE(set.size() == 6859);
    REQUIRE(same_bits(set.positions, read_particles(f).positions));
    const auto& d = attribute(set, "density");
    REQUIRE(d.components == 1);
    REQUIRE(d.values.size() == 6859);
    CHECK(d.values[0] == 1000.1286010742188f);
    CHECK(d.values[1000] == 858.64208984375f);
    CHECK(d.values[6858] == 654.8408203125f);
    const auto& v = attribute(set, "velocity");
    REQUIRE(v.components == 3);
    REQUIRE(v.values.size() == 3 * 6859);
    CHECK(v.values[0] == 0.3670507073402405f);
    CHECK(v.values[1] == -0.41762837767601013f);
    CHECK(v.values[2] == 0.4265992343425751f);
    CHECK(v.values[3 * 6858 + 1] == -2.4216198921203613f);
    const auto& id = attribute(set, "id");
    CHECK(id.values[0] == 30.0f);
    CHECK(id.values[6858] == 6489.0f);
    REQUIRE_THROWS_WITH(read_particles((dir / "dam_break_frame_23_24389_particles.bgeo").string(), with_attributes({"velocity"})),
                        Catch::Contains("no point attribute 'velocity' (the file has none)"));
}

TEST_CASE("attribute round trips: every VTU encoding, legacy VTK ASCII/BINARY 4.2/5.1, BGEO, PLY", "[io][attributes]") {
    TempDir tmp;
    const auto pts = sample_points();
    const std::size_t n = pts.size() / 3;
    const auto attrs = round_trip_attributes(n);
    const auto opts = with_attributes({"velocity", "density", "pressure"});
    auto check = [&](const std::string& file) {
        const ParticleSet set = read_particles(file, opts);
        REQUIRE(same_bits(set.positions, pts));
        REQUIRE(set.attributes.size() == 3);
        CHECK(set.attributes[0].name == "velocity");
        for (const auto& a : attrs) require_attribute(set, a);
        CHECK(set.dropped_invalid == 0);
    };
    for (const auto& v : vtu_variants()) {
        INFO("VTU " << v.name);
        write_bytes(tmp.file("a.vtu"), make_vtu(pts, v, attrs));
        check(tmp.file("a.vtu"));
    }
    for (bool binary : {false, true})
        for (bool v5 : {false, true}) {
            INFO("VTK " << (binary ? "BINARY " : "ASCII ") << (v5 ? "5.1" : "4.2"));
            write_bytes(tmp.file("a.vtk"), vtk_with_data(pts, attrs, binary, v5));
            check(tmp.file("a.vtk"));
        }
    for (const std::string fmt : {"ascii", "binary_little_endian", "binary_big_endian"}) {
        INFO("PLY " << fmt);
        write_bytes(tmp.file("a.ply"), ply_file(pts, fmt, false, attrs));
        check(tmp.file("a.ply"));
    }
    // BGEO: the generator's attributes, gzip'd and plain
    for (bool gz : {false, true}) {
        INFO("BGEO gzip " << gz);
        write_bytes(tmp.file("a.bgeo"), gz ? gzip(bgeo_file(pts, true)) : bgeo_file(pts, true));
        const ParticleSet set = read_particles(tmp.file("a.bgeo"), with_attributes({"density", "velocity", "id"}));
        REQUIRE(same_bits(set.positions, pts));
        TestAttribute density{"density", 1, {}}, velocity{"velocity", 3, {}}, id{"id", 1, {}};
        for (std::size_t i = 0; i < n; ++i) {
            density.values.push_back(1000.0f + 0.25f * float(i));
            velocity.values.insert(velocity.values.end(), {float(i), -0.5f * float(i), 2.0f + float(i)});
            id.values.push_back(float(i));
        }
        for (const auto& a : {density, velocity, id}) require_attribute(set, a);
        REQUIRE_THROWS_WITH(read_particles(tmp.file("a.bgeo"), with_attributes({"kind"})),
                            Catch::Contains("attribute 'kind' holds strings, expected numbers"));
        REQUIRE_THROWS_WITH(read_particles(tmp.file("a.bgeo"), with_attributes({"mass"})),
                            Catch::Contains("no point attribute 'mass' (the file has: id, velocity, kind, density)"));
    }
    // XYZ carries none
    write_bytes(tmp.file("a.xyz"), std::string(reinterpret_cast<const char*>(pts.data()), pts.size() * 4));
    REQUIRE_THROWS_WITH(read_particles(tmp.file("a.xyz"), with_attributes({"density"})),
                        Catch::Contains("a.xyz: no point attribute 'density' (the file has none)"));
}

TEST_CASE("attribute requests: duplicates read once, PLY triplets nx/ny/nz, multi-piece VTU", "[io][attributes]") {
    TempDir tmp;
    const auto pts = sample_points();
    const std::size_t n = pts.size() / 3;
    const auto attrs = round_trip_attributes(n);
    write_bytes(tmp.file("a.vtu"), make_vtu(pts, {"raw", "appended"}, attrs));
    const auto set = read_particles(tmp.file("a.vtu"), with_attributes({"density", "density"}));
    REQUIRE(set.attributes.size() == 1);
    require_attribute(set, attrs[0]);

    // PLY normals as nx, ny, nz: asked for as "n"
    std::string ply = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                      "property float nx\nproperty float ny\nproperty float nz\nproperty uchar level\nend_header\n"
                      "0 0 0 1 0 0 2\n1 1 1 0 0.5 -1 3\n";
    write_bytes(tmp.file("n.ply"), ply);
    const auto normals = read_particles(tmp.file("n.ply"), with_attributes({"n", "level"}));
    require_attribute(normals, {"n", 3, {1, 0, 0, 0, 0.5f, -1}});
    require_attribute(normals, {"level", 1, {2, 3}});
    REQUIRE_THROWS_WITH(read_particles(tmp.file("n.ply"), with_attributes({"velocity"})),
                        Catch::Contains("no point attribute 'velocity' (the file has: x, y, z, nx, ny, nz, level)"));
    REQUIRE_THROWS_WITH(read_particles(tmp.file("n.ply"), with_attributes({"x"})), Catch::Contains("already read as a coordinate"));

    // two pieces: attributes concatenated like the positions; a piece without one is an error
    const std::vector<float> first(pts.begin(), pts.begin() + 6), second(pts.begin() + 6, pts.end());
    const TestAttribute d1 = test_attribute("density", 1, 2, 1.0f), d2 = test_attribute("density", 1, 2, 9.0f);
    const VtuVariant ascii{"ascii", "ascii"};
    auto piece = [&](const std::vector<float>& p, const std::vector<TestAttribute>& a) {
        const std::string f = make_vtu(p, ascii, a);
        const auto b = f.find("<Piece"), e = f.find("</Piece>") + 8;
        return f.substr(b, e - b);
    };
    const std::string one = make_vtu(first, ascii, {d1});
    const std::string two = one.substr(0, one.find("</Piece>") + 8) + "\n" + piece(second, {d2}) + one.substr(one.find("</Piece>") + 8);
    write_bytes(tmp.file("two.vtu"), two);
    const auto both = read_particles(tmp.file("two.vtu"), with_attributes({"density"}));
    REQUIRE(same_bits(both.positions, pts));
    std::vector<float> dv = d1.values;
    dv.insert(dv.end(), d2.values.begin(), d2.values.end());
    require_attribute(both, {"density", 1, dv});
    const std::string gap = one.substr(0, one.find("</Piece>") + 8) + "\n" + piece(second, {test_attribute("mass", 1, 2, 0)}) +
                            one.substr(one.find("</Piece>") + 8);
    write_bytes(tmp.file("gap.vtu"), gap);
    REQUIRE_THROWS_WITH(read_particles(tmp.file("gap.vtu"), with_attributes({"density"})),
                        Catch::Contains("attribute 'density' holds 2 values, expected 4"));
}

TEST_CASE("drop_invalid: NaN/Inf particles dropped with their attribute values, counted, all dropped is an error",
          "[io][attributes]") {
    TempDir tmp;
    auto pts = sample_points();  // 4 particles
    pts[3 * 1 + 1] = NAN;        // particle 1
    pts[3 * 3 + 2] = -INFINITY;  // particle 3
    const std::vector<float> kept = {pts[0], pts[1], pts[2], pts[6], pts[7], pts[8]};
    const auto attrs = round_trip_attributes(4);
    auto kept_values = [&](const TestAttribute& a) {
        TestAttribute k{a.name, a.components, {}};
        for (std::size_t i : {0, 2})
            for (int c = 0; c < a.components; ++c) k.values.push_back(a.values[i * a.components + c]);
        return k;
    };
    std::vector<std::pair<std::string, std::string>> files = {
        {"d.vtu", make_vtu(pts, {"appended raw zlib", "appended", true}, attrs)},
        {"d2.vtu", make_vtu(pts, {"ascii", "ascii"}, attrs)},
        {"d.vtk", vtk_with_data(pts, attrs, true, false)},
        {"d2.vtk", vtk_with_data(pts, attrs, false, true)},
        {"d.ply", ply_file(pts, "binary_big_endian", true, attrs)},
        {"d2.ply", ply_file(pts, "ascii", false, attrs)},
    };
    for (const auto& [name, bytes] : files) {
        INFO(name);
        write_bytes(tmp.file(name), bytes);
        REQUIRE_THROWS_WITH(read_particles(tmp.file(name)), Catch::Contains("non-finite") || Catch::Contains("not a finite"));
        const auto set = read_particles(tmp.file(name), with_attributes({"velocity", "density"}, true));
        CHECK(set.dropped_invalid == 2);
        REQUIRE(same_bits(set.positions, kept));
        require_attribute(set, kept_values(attrs[1]));
        require_attribute(set, kept_values(attrs[0]));
    }
    // BGEO and XYZ, positions only
    write_bytes(tmp.file("d.bgeo"), gzip(bgeo_file(pts, true)));
    write_bytes(tmp.file("d.xyz"), std::string(reinterpret_cast<const char*>(pts.data()), pts.size() * 4));
    for (const char* name : {"d.bgeo", "d.xyz"}) {
        INFO(name);
        ReadOptions drop;
        drop.drop_invalid = true;
        const auto set = read_particles(tmp.file(name), drop);
        CHECK(set.dropped_invalid == 2);
        REQUIRE(same_bits(set.positions, kept));
    }
    const auto bgeo = read_particles(tmp.file("d.bgeo"), with_attributes({"id"}, true));
    require_attribute(bgeo, {"id", 1, {0, 2}});
    // a value beyond the float range in a double file counts as Inf
    const std::string big = "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\nproperty double z\n"
                            "end_header\n1 2 3\n1e300 0 0\n";
    write_bytes(tmp.file("big.ply"), big);
    ReadOptions drop;
    drop.drop_invalid = true;
    CHECK(read_particles(tmp.file("big.ply"), drop).dropped_invalid == 1);
    // nothing valid left
    const std::vector<float> all_nan = {NAN, 0, 0, 0, INFINITY, 0};
    write_bytes(tmp.file("nan.xyz"), std::string(reinterpret_cast<const char*>(all_nan.data()), all_nan.size() * 4));
    REQUIRE_THROWS_WITH(read_particles(tmp.file("nan.xyz"), drop),
                        Catch::Contains("nan.xyz: no valid particles: all 2 have NaN/Inf coordinates"));
    // without NaN nothing is dropped, and an empty file of particles stays empty
    write_bytes(tmp.file("ok.xyz"), std::string(reinterpret_cast<const char*>(kept.data()), kept.size() * 4));
    CHECK(read_particles(tmp.file("ok.xyz"), drop).dropped_invalid == 0);
    write_bytes(tmp.file("zero.vtk"), vtk_binary({}, "4.2", "POLYDATA", false));
    CHECK(read_particles(tmp.file("zero.vtk"), drop).size() == 0);
}
