// Particle readers: every real data file, every encoding variant, and hostile files.
#include <cmath>
#include <cstring>
#include <fstream>
#include <regex>

#include <zlib.h>

#include "io_test_files.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"

using trilevel::read_particles;
using trilevel::test::TempDir;
using namespace trilevel::test;

namespace {

void require_same(const trilevel::ParticleSet& set, const std::vector<float>& expected) {
    REQUIRE(set.positions.size() == expected.size());
    REQUIRE(std::memcmp(set.positions.data(), expected.data(), expected.size() * sizeof(float)) == 0);
}

/// Sample points without values that text output at %.9g cannot round-trip through double formats.
std::vector<float> text_safe_points() { return sample_points(); }

}  // namespace

TEST_CASE("every shared data file reads with its exact count and finite coordinates", "[io]") {
    TRILEVEL_REQUIRE_SHARED_DATA(dir);
    const std::regex count_re("_([0-9]+)_particles\\.");
    int files = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        std::smatch m;
        if (!std::regex_search(name, m, count_re)) continue;
        // the bunny frame's name gives the last particle id; it holds 7706 particles
        const std::size_t expected = name == "bunny_frame_14_7705_particles.vtk" ? 7706 : std::stoul(m[1]);
        INFO(name);
        const auto set = read_particles(entry.path().string());
        CHECK(set.size() == expected);
        CHECK(std::all_of(set.positions.begin(), set.positions.end(), [](float c) { return std::isfinite(c); }));
        ++files;
    }
    CHECK(files >= 12);
}

TEST_CASE("VTU: every encoding reads the same floats", "[io]") {
    TempDir tmp;
    const auto pts = sample_points();
    const auto variants = vtu_variants();
    for (const auto& v : variants) {
        INFO(v.name);
        const std::string f = tmp.file("p.vtu");
        write_bytes(f, make_vtu(pts, v));
        require_same(read_particles(f), pts);
    }
}

TEST_CASE("legacy VTK: binary float/double, 4.2 and 5.1, POLYDATA and UNSTRUCTURED_GRID, ASCII", "[io]") {
    TempDir tmp;
    const auto pts = sample_points();
    const std::string f = tmp.file("p.vtk");
    write_bytes(f, vtk_binary(pts, "4.2", "POLYDATA", false));
    require_same(read_particles(f), pts);
    write_bytes(f, vtk_binary(pts, "5.1", "UNSTRUCTURED_GRID", true));
    require_same(read_particles(f), pts);
    write_bytes(f, vtk_ascii(text_safe_points(), "float"));
    require_same(read_particles(f), text_safe_points());
    write_bytes(f, vtk_ascii(text_safe_points(), "double"));
    require_same(read_particles(f), text_safe_points());
}

TEST_CASE("PLY: ascii and binary LE/BE, float and double, other elements and properties skipped", "[io]") {
    TempDir tmp;
    const auto pts = sample_points();
    const std::string f = tmp.file("p.ply");
    for (const std::string fmt : {"ascii", "binary_little_endian", "binary_big_endian"})
        for (bool doubles : {false, true}) {
            INFO(fmt << (doubles ? " double" : " float"));
            write_bytes(f, ply_file(pts, fmt, doubles));
            require_same(read_particles(f), pts);
        }
}

TEST_CASE("BGEO: gzip'd and plain, with and without extra point attributes", "[io]") {
    TempDir tmp;
    const auto pts = sample_points();
    const std::string f = tmp.file("p.bgeo");
    for (bool attrs : {false, true}) {
        write_bytes(f, bgeo_file(pts, attrs));
        require_same(read_particles(f), pts);
        write_bytes(f, gzip(bgeo_file(pts, attrs)));
        require_same(read_particles(f), pts);
    }
}

TEST_CASE("XYZ: raw little-endian float32 triplets, extension matched case-insensitively", "[io]") {
    TempDir tmp;
    const auto pts = sample_points();
    std::string bytes(reinterpret_cast<const char*>(pts.data()), pts.size() * 4);
    write_bytes(tmp.file("p.XYZ"), bytes);
    require_same(read_particles(tmp.file("p.XYZ")), pts);
}

namespace {

/// A file named `name` holding `bytes` must fail to read with a message naming it and `what`.
void require_rejected(const TempDir& tmp, const std::string& name, const std::string& bytes, const std::string& what) {
    const std::string f = tmp.file(name);
    write_bytes(f, bytes);
    INFO("file " << name);
    REQUIRE_THROWS_AS(read_particles(f), trilevel::Error);
    REQUIRE_THROWS_WITH(read_particles(f), Catch::Contains(name) && Catch::Contains(what));
    try {
        read_particles(f);
    } catch (const trilevel::Error& e) {
        REQUIRE(std::string(e.what()).find('\n') == std::string::npos);
    }
}

std::string le_u64(std::uint64_t v) { return le_bytes(v); }

}  // namespace

TEST_CASE("BGEO: large gzip'd point data (one inflate call) reads as the plain file, in one gzip member or two", "[io]") {
    TempDir tmp;
    std::vector<float> pts;
    for (int i = 0; i < 60000; ++i)  // 60k records of 40 bytes: over the 1 MiB where one call takes over
        for (int k = 0; k < 3; ++k) pts.push_back(0.001f * float((i * 7 + k * 13) % 100003) - 3.0f);
    const std::string plain = bgeo_file(pts, true), f = tmp.file("big.bgeo");
    write_bytes(f, plain);
    const trilevel::ParticleSet want = read_particles(f);
    write_bytes(f, gzip(plain));
    require_same(read_particles(f), pts);
    const std::size_t half = plain.size() / 2;  // two members: the footer gives only the second's size
    write_bytes(f, gzip(plain.substr(0, half)) + gzip(plain.substr(half)));
    const trilevel::ParticleSet two = read_particles(f);
    require_same(two, pts);
    REQUIRE(two.attributes.size() == want.attributes.size());
    std::string wrong = gzip(plain);  // a footer that lies about the size: zlib's check names it
    wrong[wrong.size() - 1] ^= 0x01;
    require_rejected(tmp, "footer.bgeo", wrong, "gzip");
    require_rejected(tmp, "cut.bgeo", gzip(plain).substr(0, plain.size() / 8), "truncated");
}

// The one-call inflate hands its buffer over to the positions, rewritten in place: the attributes
// come from the records first, and a non-finite coordinate is found before anything is moved.
TEST_CASE("BGEO: a large gzip'd file's attributes and non-finite coordinates read as in the plain file", "[io]") {
    TempDir tmp;
    std::vector<float> pts;
    for (int i = 0; i < 60000; ++i)
        for (int k = 0; k < 3; ++k) pts.push_back(0.001f * float((i * 11 + k * 17) % 100019) - 2.0f);
    trilevel::ReadOptions with;
    with.attributes = {"density", "velocity", "id"};
    const std::string plain = bgeo_file(pts, true), f = tmp.file("big.bgeo");
    write_bytes(f, plain);
    const trilevel::ParticleSet want = read_particles(f, with);
    write_bytes(f, gzip(plain));
    const trilevel::ParticleSet got = read_particles(f, with);
    require_same(got, pts);
    REQUIRE(got.positions.size() == 3 * 60000);
    REQUIRE(got.attributes.size() == 3);
    for (std::size_t a = 0; a < 3; ++a) {
        INFO("attribute " << want.attributes[a].name);
        REQUIRE(got.attributes[a].name == want.attributes[a].name);
        REQUIRE(got.attributes[a].components == want.attributes[a].components);
        REQUIRE(got.attributes[a].values.size() == want.attributes[a].values.size());
        REQUIRE(std::memcmp(got.attributes[a].values.data(), want.attributes[a].values.data(),
                            want.attributes[a].values.size() * sizeof(float)) == 0);
    }
    require_same(read_particles(f), pts);  // no attributes asked: the same positions

    // Particle 41234's y is NaN, its last z infinite: both readings name the first, at one offset.
    std::vector<float> bad = pts;
    bad[3 * 41234 + 1] = std::nanf("");
    bad[3 * 59999 + 2] = INFINITY;
    const std::string bad_plain = bgeo_file(bad, true);
    const std::size_t record = 4 * (4 + 1 + 3 + 1 + 1), offset = bad_plain.size() - 2 - 60000 * record + 41234 * record + 4;
    const std::string where = "offset " + std::to_string(offset);
    write_bytes(f, bad_plain);
    REQUIRE_THROWS_WITH(read_particles(f, with), Catch::Contains(where + ": particle 41234: non-finite coordinate"));
    write_bytes(f, gzip(bad_plain));
    REQUIRE_THROWS_WITH(read_particles(f, with), Catch::Contains(where + " (uncompressed): particle 41234: non-finite coordinate"));
    REQUIRE_THROWS_WITH(read_particles(f), Catch::Contains(where + " (uncompressed): particle 41234: non-finite"));
}

TEST_CASE("hostile and malformed particle files are rejected with one-line errors naming the file", "[io]") {
    TempDir tmp;
    const auto pts = sample_points();
    const std::string vtk_good = vtk_binary(pts, "4.2", "UNSTRUCTURED_GRID", false);
    const std::string header = "# vtk DataFile Version 4.2\nx\nBINARY\nDATASET POLYDATA\n";

    // legacy VTK
    require_rejected(tmp, "truncated.vtk", vtk_good.substr(0, 100), "truncated");
    require_rejected(tmp, "huge.vtk", header + "POINTS 1000000000000000000 float\n" + std::string(64, '\0'), "truncated");
    require_rejected(tmp, "overflow.vtk", header + "POINTS 99999999999999999999999 float\n", "expected POINTS");
    require_rejected(tmp, "nopoints.vtk", header + "VERTICES 0 0\n", "expected POINTS");
    require_rejected(tmp, "badtype.vtk", header + "POINTS 1 quaternion\n", "unsupported POINTS type");
    require_rejected(tmp, "nomagic.vtk", "hello\nworld\n", "not a legacy VTK file");
    require_rejected(tmp, "badmode.vtk", "# vtk DataFile Version 4.2\nx\nTEXT\n", "ASCII or BINARY");
    require_rejected(tmp, "nan.vtk", "# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0\n1 nan 2\n", "non-finite");
    require_rejected(tmp, "inf.vtk", header + "POINTS 1 float\n" + be_bytes(1.0f) + be_bytes(INFINITY) + be_bytes(0.0f), "non-finite");
    require_rejected(tmp, "badnumber.vtk", "# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\nPOINTS 1 float\n0 zero 0\n", "line 6: malformed number");
    require_rejected(tmp, "shortascii.vtk", "# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n0 0 0 1\n", "truncated ASCII");
    {  // binary coordinates cannot tell a wrong count: the keyword line after them must follow
        const std::string n = std::to_string(pts.size() / 3), good = vtk_binary(pts, "4.2", "POLYDATA", false);
        const std::size_t at = good.find("POINTS " + n) + 7;
        require_rejected(tmp, "countplus.vtk", good.substr(0, at) + std::to_string(pts.size() / 3 + 1) + good.substr(at + n.size()),
                         "'0' follows the binary POINTS: expected a section such as CELLS or POINT_DATA");
        require_rejected(tmp, "countminus.vtk", good.substr(0, at) + std::to_string(pts.size() / 3 - 1) + good.substr(at + n.size()),
                         "binary data follows the binary POINTS");
        write_bytes(tmp.file("ok.vtk"), good);  // the right count: read as written
        require_same(read_particles(tmp.file("ok.vtk")), pts);
    }
    require_rejected(tmp, "toolarge.vtk", "# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\nPOINTS 1 double\n1e300 0 0\n", "beyond the float range");

    // VTU
    const std::string vtu = make_vtu(pts, {"raw zlib", "appended", true});
    require_rejected(tmp, "truncated.vtu", vtu.substr(0, vtu.size() - 120), "truncated");
    VtuVariant b64v{"b64", "binary"};
    std::string bad64 = make_vtu(pts, b64v);
    bad64[bad64.find("format=\"binary\">") + 20] = '*';
    require_rejected(tmp, "badbase64.vtu", bad64, "bad base64");
    std::string badz = make_vtu(pts, {"zlib", "appended", true});
    // header: 3 + 6 words of 8 bytes; then the first compressed block
    badz[badz.find('_', badz.find("<AppendedData")) + 1 + 72 + 3] ^= 0x55;
    require_rejected(tmp, "badzlib.vtu", badz, "bad zlib block 0");
    std::string huge = make_vtu(pts, {"raw", "appended"});
    huge.replace(huge.find("NumberOfPoints=\"4\""), 18, "NumberOfPoints=\"1000000000000000000\"");
    require_rejected(tmp, "hugepoints.vtu", huge, "NumberOfPoints");
    std::string wrongsize = make_vtu(pts, {"raw", "appended"});
    const std::size_t u = wrongsize.find('_', wrongsize.find("<AppendedData"));
    wrongsize.replace(u + 1, 8, le_u64(1ull << 60));
    require_rejected(tmp, "wrongsize.vtu", wrongsize, "expected 96");
    require_rejected(tmp, "noxml.vtu", "just text", "no <VTKFile>");
    std::string nanvtu = make_vtu({0, 0, 0, NAN, 1, 2}, {"ascii", "ascii"});
    require_rejected(tmp, "nan.vtu", nanvtu, "particle 1");
    std::string lzma = make_vtu(pts, b64v);
    lzma.replace(lzma.find("header_type"), 0, "compressor=\"vtkLZMADataCompressor\" ");
    require_rejected(tmp, "lzma.vtu", lzma, "unsupported compressor");

    {  // header_type naming the other width: UInt32 over 64-bit headers passes every size check and
       // reads each value 4 bytes early; the block's end against the next block's offset tells
        const TestAttribute density{"density", 1, {1, 2, 3, 4}};
        for (const bool with_attribute : {false, true}) {  // Points last in the appended data, or followed
            const auto attrs = with_attribute ? std::vector<TestAttribute>{density} : std::vector<TestAttribute>{};
            std::string u64_as_u32 = make_vtu(pts, {"raw", "appended"}, attrs);
            u64_as_u32.replace(u64_as_u32.find("header_type=\"UInt64\""), 20, "header_type=\"UInt32\"");
            require_rejected(tmp, "u64as32.vtu", u64_as_u32, "header_type=\"UInt32\", but the appended block at offset 0 has a 64-bit size header");
            std::string u32_as_u64 = make_vtu(pts, {"raw u32", "appended", false, false, false, true}, attrs);
            u32_as_u64.replace(u32_as_u64.find("header_type=\"UInt32\""), 20, "header_type=\"UInt64\"");
            require_rejected(tmp, "u32as64.vtu", u32_as_u64, "has a 32-bit size header");
        }
        // Four bytes after the last block of a UInt32 file end it where a 64-bit header would, but its
        // header read in 64 bits takes in the first value's bytes and gives another size: no mismatch
        // (the first version of the check refused such files). A first value of +0.0 would make both
        // readings consistent (as would a Float64 value whose low word is zero, 1.5 among them); the check
        // then believes the block's end over the declaration.
        std::vector<float> first_nonzero = pts;
        first_nonzero[0] = 1.5f;
        std::string trailing = make_vtu(first_nonzero, {"raw u32 f32", "appended", false, false, false, true, false, true});
        trailing.replace(trailing.find("\n</AppendedData>"), 0, "abcd");
        write_bytes(tmp.file("trailing.vtu"), trailing);
        require_same(read_particles(tmp.file("trailing.vtu")), first_nonzero);
        // A malformed tag in a section the reader skips ends the check's scan of offsets, not the read.
        std::string skipped = make_vtu(pts, {"raw", "appended"});
        skipped.replace(skipped.find("</Piece>"), 0, "<CellData><DataArray Name=\"broken></CellData>\n");
        write_bytes(tmp.file("skipped.vtu"), skipped);
        require_same(read_particles(tmp.file("skipped.vtu")), pts);
    }
    std::string badtag = make_vtu(pts, {"raw", "appended"});
    badtag.replace(badtag.find("<AppendedData "), 14, "<AppendedDataX");
    require_rejected(tmp, "badtag.vtu", badtag, "malformed <AppendedData> tag");
    std::string multiline = make_vtu(pts, b64v);
    multiline.replace(multiline.find("\"UInt64\""), 8, "\"UInt\n64\"");
    require_rejected(tmp, "multiline.vtu", multiline, "unsupported header_type");  // and still one line

    // BGEO
    require_rejected(tmp, "magic.bgeo", gzip("BgeoX" + std::string(40, '\0')), "BgeoV");
    require_rejected(tmp, "plainmagic.bgeo", "NotBgeo at all", "BgeoV");
    require_rejected(tmp, "truncated.bgeo", gzip(bgeo_file(pts, true).substr(0, 150)), "truncated");
    require_rejected(tmp, "badgzip.bgeo", gzip(bgeo_file(pts, true)).substr(0, 40), "gzip");
    std::string version = bgeo_file(pts, false);
    version.replace(5, 4, be_bytes(std::int32_t(9)));
    require_rejected(tmp, "version.bgeo", version, "version 9");
    std::string bighead = bgeo_file(pts, false);
    bighead.replace(9, 4, be_bytes(std::int32_t(0x7fffffff)));
    require_rejected(tmp, "hugecount.bgeo", bighead, "point count 2147483647 of 16 bytes needs 34.4 GB but the file has 107 bytes");
    std::vector<float> nanpts = pts;
    nanpts[4] = NAN;
    require_rejected(tmp, "nan.bgeo", gzip(bgeo_file(nanpts, true)), "non-finite");

    // PLY
    std::string nox = ply_file(pts, "binary_little_endian", false);
    nox.replace(nox.find(" x\n"), 3, " w\n");
    require_rejected(tmp, "nox.ply", nox, "lacks property x");
    require_rejected(tmp, "noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "end_header");
    require_rejected(tmp, "notply.ply", "plx\n", "not a PLY file");
    const std::string plyhead = "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    require_rejected(tmp, "huge.ply", plyhead + std::string(24, '\0'), "truncated");
    const std::string plytrunc = ply_file(pts, "binary_big_endian", true);
    require_rejected(tmp, "truncated.ply", plytrunc.substr(0, plytrunc.size() - 5), "truncated");
    require_rejected(tmp, "badformat.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", "line 2");
    require_rejected(tmp, "nan.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 inf 2\n", "non-finite");

    // XYZ and generic
    require_rejected(tmp, "odd.xyz", std::string(13, '\0'), "multiple of 12");
    std::string nanxyz(12, '\0');
    const float nanf = NAN;
    std::memcpy(&nanxyz[4], &nanf, 4);
    require_rejected(tmp, "nan.xyz", nanxyz, "particle 0");
    require_rejected(tmp, "empty.vtk", "", "empty file");
    require_rejected(tmp, "empty.xyz", "", "empty file");
    require_rejected(tmp, "particles.txt", "1 2 3", "unknown particle file extension");
}

TEST_CASE("missing files and directories are clear errors", "[io]") {
    TempDir tmp;
    REQUIRE_THROWS_WITH(read_particles(tmp.file("absent.vtk")), Catch::Contains("absent.vtk") && Catch::Contains("no such file"));
    std::filesystem::create_directories(tmp.path / "dir.vtk");
    REQUIRE_THROWS_WITH(read_particles(tmp.file("dir.vtk")), Catch::Contains("dir.vtk") && Catch::Contains("is a directory"));
}

TEST_CASE("a missing file is reported as missing even with an unknown extension", "[io]") {
    TempDir tmp;
    REQUIRE_THROWS_WITH(read_particles(tmp.file("absent.abc")), Catch::Contains("absent.abc: no such file"));
    REQUIRE_THROWS_WITH(trilevel::read_mesh(tmp.file("absent.stl")), Catch::Contains("absent.stl: no such file"));
}
