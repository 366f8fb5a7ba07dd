// Hostile-input corpus for the particle readers, every file written by the test: truncations at
// every cut point, huge and negative counts, wrong types, NaN/Inf, empty files, directories,
// garbage, zlib/gzip bombs and corruption, wrong endianness flags, short attribute arrays.
// Each must end as one trilevel::Error naming the file and the problem (no crash, no huge
// allocation), and through the CLI as one stderr line, a non-zero exit and no output file.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include "io/particle_formats.hpp"
#include "io_test_files.hpp"
#include "cli_test_support.hpp"
#include "trilevel/io.hpp"

using trilevel::ReadOptions;
using trilevel::read_particles;
using namespace trilevel::test;

namespace {

struct HostileCase {
    std::string cls;    ///< the class of bad input
    std::string name;   ///< file name (its extension picks the reader)
    std::string bytes;  ///< content; "<dir>" makes a directory
    std::string what;   ///< a part of the expected message
    std::vector<std::string> attributes = {};
};

std::string garbage(std::size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::string s(n, '\0');
    for (char& c : s) c = static_cast<char>(rng() & 0xff);
    return s;
}

std::string replace_once(std::string s, const std::string& from, const std::string& to) {
    const auto at = s.find(from);
    INFO("replacing '" << from << "'");
    REQUIRE(at != std::string::npos);
    return s.replace(at, from.size(), to);
}

std::string i32be(std::int32_t v) { return be_bytes(v); }

/// Offset of the appended payload ('_' + 1) of a VTU file.
std::size_t appended_start(const std::string& vtu) { return vtu.find('_', vtu.find("<AppendedData")) + 1; }

std::vector<HostileCase> corpus() {
    const auto pts = sample_points();  // 4 particles
    const auto attrs = std::vector<TestAttribute>{test_attribute("density", 1, 4, 1000.0f), test_attribute("velocity", 3, 4, -2.0f)};
    const std::vector<std::string> want = {"density", "velocity"};
    std::vector<HostileCase> c;
    const std::string vtk_head = "# vtk DataFile Version 4.2\nx\nBINARY\nDATASET POLYDATA\n";
    const std::string vtk_ascii_head = "# vtk DataFile Version 4.2\nx\nASCII\nDATASET POLYDATA\n";
    const std::string ply_head = "ply\nformat binary_little_endian 1.0\n";
    const std::string xyz_props = "property float x\nproperty float y\nproperty float z\n";
    const std::string bgeo_plain = bgeo_file(pts, true);
    const std::string vtk_attr_bin = vtk_with_data(pts, attrs, true, false);
    const std::string vtk_attr_ascii = vtk_with_data(pts, attrs, false, true);

    // --- empty files and directories, every extension
    for (const char* ext : {"vtk", "vtu", "bgeo", "ply", "xyz"}) {
        c.push_back({"empty file", std::string("empty.") + ext, "", "empty file"});
        c.push_back({"directory", std::string("dir.") + ext, "<dir>", "is a directory"});
    }

    // --- garbage bytes, alone and behind each format's magic
    for (const char* ext : {"vtk", "vtu", "bgeo", "ply"}) c.push_back({"garbage", std::string("garbage.") + ext, garbage(4099, 7), ""});
    c.push_back({"garbage", "garbage.xyz", garbage(4099, 7), "not a multiple of 12"});
    c.push_back({"garbage", "magic.vtk", "# vtk DataFile Version 4.2\nx\nBINARY\n" + garbage(3000, 8), ""});
    c.push_back({"garbage", "magic.ply", "ply\n" + garbage(3000, 9), ""});
    c.push_back({"garbage", "magic.bgeo", "BgeoV" + garbage(3000, 10), "version"});
    c.push_back({"garbage", "gzmagic.bgeo", "\x1f\x8b" + garbage(3000, 11), "bad gzip stream"});
    c.push_back({"garbage", "magic.vtu", "<VTKFile type=\"UnstructuredGrid\">" + garbage(3000, 12), ""});
    c.push_back({"garbage", "text.vtu", "<?xml version=\"1.0\"?><note>not VTK</note>", "no <VTKFile>"});

    // --- headers claiming huge counts (each must fail before allocating)
    c.push_back({"huge count", "huge.vtk", vtk_head + "POINTS 1000000000000000000 float\n" + std::string(64, '\0'), "need 12 EB, only 64 bytes left"});
    c.push_back({"huge count", "hugeascii.vtk", vtk_ascii_head + "POINTS 1000000000000000000 float\n0 0 0\n", "cannot fit"});
    c.push_back({"huge count", "huge63.vtk", vtk_head + "POINTS 9223372036854775807 float\n", "impossible"});
    c.push_back({"huge count", "hugefield.vtk", vtk_head + "FIELD f 1\nt 1 1000000000000000000 double\n", "truncated binary data"});
    c.push_back({"huge count", "hugefield2.vtk", vtk_head + "FIELD f 1\nt 4611686018427387904 8 double\n", "overflows"});
    c.push_back({"huge count", "hugecells.vtk", replace_once(vtk_attr_bin, "CELLS 4 8", "CELLS 4 1000000000000000000"), "truncated binary data", want});
    c.push_back({"huge count", "hugetex.vtk", replace_once(vtk_attr_bin, "uv 2 float", "uv 4611686018427387904 float"), "overflows", want});
    c.push_back({"huge count", "hugelut.vtk", replace_once(vtk_attr_bin, "COLOR_SCALARS rgb 3", "COLOR_SCALARS rgb 100000000000"), "truncated binary data", want});
    c.push_back({"huge count", "hugepoints.vtu", replace_once(make_vtu(pts, {"raw", "appended"}), "NumberOfPoints=\"4\"", "NumberOfPoints=\"1000000000000000000\""), "NumberOfPoints=1000000000000000000"});
    c.push_back({"huge count", "maxpoints.vtu", replace_once(make_vtu(pts, {"raw", "appended"}), "NumberOfPoints=\"4\"", "NumberOfPoints=\"18446744073709551615\""), "overflows"});
    {
        std::string v = make_vtu(pts, {"raw", "appended"});
        v.replace(appended_start(v), 8, le_bytes(std::uint64_t(1) << 60));
        c.push_back({"huge count", "hugeheader.vtu", v, "holds 1152921504606846976 bytes, expected 96"});
        std::string z = make_vtu(pts, {"zlib", "appended", true});
        z.replace(appended_start(z), 8, le_bytes(std::uint64_t(1) << 40));
        c.push_back({"huge count", "hugeblocks.vtu", z, "claims 1099511627776 blocks"});
        std::string b = make_vtu(pts, {"b64", "binary"});
        const auto at = b.find("format=\"binary\">") + 16;
        const auto end = b.find("</DataArray>", at);
        b.replace(at, end - at, b64(le_bytes(std::uint64_t(1) << 62)) + b64(std::string(96, '\0')));
        c.push_back({"huge count", "hugeb64.vtu", b, "holds 4611686018427387904 bytes, expected 96"});
    }
    {
        std::string b = bgeo_file(pts, false);
        b.replace(9, 4, i32be(0x7fffffff));
        c.push_back({"huge count", "hugecount.bgeo", b, "point count 2147483647 of 16 bytes needs 34.4 GB but the file has"});
        c.push_back({"huge count", "hugecountgz.bgeo", gzip(b), "(at most"});
        std::string a = bgeo_file(pts, false);
        a.replace(25, 4, i32be(0x7fffffff));  // point attribute count
        c.push_back({"huge count", "hugeattrs.bgeo", a, "offset 25: point attribute count 2147483647 needs at least 17.2 GB but the file has"});
        std::string s = bgeo_plain;
        s = replace_once(s, "kind" + be_bytes(std::uint16_t(1)) + i32be(4) + i32be(2), "kind" + be_bytes(std::uint16_t(1)) + i32be(4) + i32be(0x7fffffff));
        c.push_back({"huge count", "hugestrings.bgeo", s, "truncated string"});
        std::string big = bgeo_plain;
        big = replace_once(big, be_bytes(std::uint16_t(8)) + "velocity" + be_bytes(std::uint16_t(3)), be_bytes(std::uint16_t(8)) + "velocity" + be_bytes(std::uint16_t(65535)));
        c.push_back({"huge count", "hugesize.bgeo", big, "truncated attribute defaults"});
    }
    c.push_back({"huge count", "huge.ply", ply_head + "element vertex 1000000000000000000\n" + xyz_props + "end_header\n" + std::string(24, '\0'), "1000000000000000000 vertices of at least 12 bytes cannot fit"});
    c.push_back({"huge count", "hugeascii.ply", "ply\nformat ascii 1.0\nelement vertex 1000000000000000000\n" + xyz_props + "end_header\n0 0 0\n", "vertices cannot fit"});
    c.push_back({"huge count", "hugefirst.ply", ply_head + "element camera 1000000000000000000\nproperty float fov\nelement vertex 1\n" + xyz_props + "end_header\n" + std::string(16, '\0'), "truncated PLY data"});
    c.push_back({"huge count", "hugelist.ply", ply_head + "element vertex 1\nproperty list uint float extra\n" + xyz_props + "end_header\n" + le_bytes(std::uint32_t(4000000000u)) + std::string(12, '\0'), "truncated PLY data"});
    c.push_back({"huge count", "hugelistascii.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float extra\n" + xyz_props + "end_header\n1e300 0 0 0\n", "bad list length"});

    // --- negative counts
    c.push_back({"negative count", "negative.vtk", vtk_head + "POINTS -5 float\n", "expected POINTS <n> <type>, found '-5'"});
    c.push_back({"negative count", "negcells.vtk", replace_once(vtk_attr_bin, "CELLS 4 8", "CELLS 4 -8"), "line 8: expected CELLS <n> <size>, found '-8'", want});
    c.push_back({"negative count", "negpointdata.vtk", replace_once(vtk_attr_bin, "POINT_DATA 4", "POINT_DATA -4"), "expected POINT_DATA <n>, found '-4'", want});
    {
        std::string b = bgeo_file(pts, false);
        b.replace(9, 4, i32be(-1));
        c.push_back({"negative count", "negative.bgeo", b, "negative point count -1"});
        std::string a = bgeo_file(pts, false);
        a.replace(25, 4, i32be(-3));
        c.push_back({"negative count", "negattrs.bgeo", a, "negative point attribute count -3"});
        std::string s = replace_once(bgeo_plain, "kind" + be_bytes(std::uint16_t(1)) + i32be(4) + i32be(2), "kind" + be_bytes(std::uint16_t(1)) + i32be(4) + i32be(-2));
        c.push_back({"negative count", "negstrings.bgeo", s, "negative string count -2 for attribute 'kind'"});
    }
    c.push_back({"negative count", "negative.ply", "ply\nformat ascii 1.0\nelement vertex -3\n" + xyz_props + "end_header\n", "line 3: expected element <name> <count>"});
    c.push_back({"negative count", "neglist.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty list char float extra\n" + xyz_props + "end_header\n-1 0 0 0\n", "bad list length"});
    c.push_back({"negative count", "neglistbin.ply", ply_head + "element vertex 1\nproperty list char float extra\n" + xyz_props + "end_header\n" + std::string(1, '\xff') + std::string(12, '\0'), "negative list length"});
    c.push_back({"negative count", "negative.vtu", replace_once(make_vtu(pts, {"ascii", "ascii"}), "NumberOfPoints=\"4\"", "NumberOfPoints=\"-4\""), "bad NumberOfPoints '-4'"});
    c.push_back({"negative count", "negoffset.vtu", replace_once(make_vtu(pts, {"raw", "appended"}), "offset=\"0\"", "offset=\"-1\""), "bad DataArray offset '-1'"});

    // --- wrong types
    c.push_back({"wrong type", "type.vtk", vtk_head + "POINTS 1 quaternion\n", "unsupported POINTS type 'quaternion'"});
    c.push_back({"wrong type", "scalartype.vtk", replace_once(vtk_attr_bin, "SCALARS density float 1", "SCALARS density text 1"), "unsupported data type 'text'", want});
    c.push_back({"wrong type", "offsetstype.vtk", replace_once(vtk_attr_ascii, "OFFSETS vtktypeint64", "OFFSETS int128"), "unsupported data type 'int128'", want});
    c.push_back({"wrong type", "tensor.vtk", replace_once(vtk_attr_bin, "VECTORS velocity float", "TENSORS velocity float"), "attribute 'velocity' has 9 components, expected 1 or 3", want});
    c.push_back({"wrong type", "keyword.vtk", replace_once(vtk_attr_ascii, "CELL_TYPES", "CELL_SHAPES"), "unexpected 'CELL_SHAPES' after POINTS", want});
    c.push_back({"wrong type", "type.vtu", replace_once(make_vtu(pts, {"raw", "appended"}), "type=\"Float64\" Name=\"Points\"", "type=\"Float16\" Name=\"Points\""), "offset 291: unsupported type 'Float16' for the Points"});
    c.push_back({"wrong type", "attrtype.vtu", replace_once(make_vtu(pts, {"ascii", "ascii"}, attrs), "type=\"Float64\" Name=\"density\"", "type=\"String\" Name=\"density\""), "unsupported type 'String' for PointData 'density'", want});
    c.push_back({"wrong type", "comps.vtu", replace_once(make_vtu(pts, {"ascii", "ascii"}), "Name=\"Points\" NumberOfComponents=\"3\"", "Name=\"Points\" NumberOfComponents=\"2\""), "Points must have NumberOfComponents=\"3\""});
    c.push_back({"wrong type", "attrcomps.vtu", replace_once(make_vtu(pts, {"ascii", "ascii"}, attrs), "Name=\"velocity\" NumberOfComponents=\"3\"", "Name=\"velocity\" NumberOfComponents=\"2\""), "PointData 'velocity' has NumberOfComponents=\"2\", expected 1 or 3", want});
    c.push_back({"wrong type", "format.vtu", replace_once(make_vtu(pts, {"raw", "appended"}), "format=\"appended\"", "format=\"hex\""), "unknown DataArray format 'hex'"});
    c.push_back({"wrong type", "format2.vtu", replace_once(make_vtu(pts, {"b64", "binary"}), "format=\"binary\"", "format=\"hex\""), "unknown DataArray format 'hex'"});
    c.push_back({"wrong type", "encoding.vtu", replace_once(make_vtu(pts, {"raw", "appended"}), "encoding=\"raw\"", "encoding=\"hex\""), "unknown AppendedData encoding 'hex'"});
    c.push_back({"wrong type", "compressor.vtu", replace_once(make_vtu(pts, {"b64", "binary"}), "header_type", "compressor=\"vtkLZMADataCompressor\" header_type"), "unsupported compressor"});
    {
        std::string t = replace_once(bgeo_plain, "velocity" + be_bytes(std::uint16_t(3)) + i32be(5), "velocity" + be_bytes(std::uint16_t(3)) + i32be(7));
        c.push_back({"wrong type", "attrtype.bgeo", t, "attribute 'velocity' has unsupported type 7"});
        std::string v = bgeo_file(pts, false);
        v.replace(5, 4, i32be(4));
        c.push_back({"wrong type", "version.bgeo", v, "BGEO version 4 unsupported, expected 5"});
        c.push_back({"wrong type", "string.bgeo", bgeo_plain, "attribute 'kind' holds strings, expected numbers", {"kind"}});
    }
    c.push_back({"wrong type", "type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n", "line 4: expected property <type> <name>"});
    c.push_back({"wrong type", "listtype.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty list float float extra\nend_header\n", "expected property list <integer type>"});
    c.push_back({"wrong type", "listcoord.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nproperty float y\nproperty float z\nend_header\n1 0 0 0\n", "lacks property x"});
    c.push_back({"wrong type", "format.ply", "ply\nformat binary_middle_endian 1.0\nend_header\n", "line 2"});

    // --- NaN / Inf coordinates, every format and encoding family
    std::vector<float> nan_pts = pts, inf_pts = pts;
    nan_pts[4] = NAN;
    inf_pts[7] = -INFINITY;
    c.push_back({"NaN/Inf", "nan.vtk", vtk_ascii(nan_pts, "float"), "line 9: particle 1: non-finite coordinate 'nan'"});
    c.push_back({"NaN/Inf", "inf.vtk", vtk_binary(inf_pts, "4.2", "POLYDATA", false), "offset 99: particle 2: non-finite"});
    c.push_back({"NaN/Inf", "big.vtk", vtk_ascii_head + "POINTS 1 double\n1e300 0 0\n",
                 "particle 0: coordinate '1e300' is beyond the float range (+-3.4e38)"});
    c.push_back({"NaN/Inf", "bigbin.vtk",
                 "# vtk DataFile Version 4.2\nx\nBINARY\nDATASET POLYDATA\nPOINTS 1 double\n" + be_bytes(0.0) +
                     be_bytes(5e300) + be_bytes(0.0) + "\n",
                 "particle 0: coordinate 5e+300 is beyond the float range (+-3.4e38)"});
    c.push_back({"NaN/Inf", "nan.vtu", make_vtu(nan_pts, {"ascii", "ascii"}), "particle 1"});
    c.push_back({"NaN/Inf", "nanraw.vtu", make_vtu(nan_pts, {"raw", "appended"}), "offset 291: the Points: particle 1"});
    c.push_back({"NaN/Inf", "infzlib.vtu", make_vtu(inf_pts, {"zlib", "binary", true, false, false, false, false, true}), "particle 2"});
    c.push_back({"NaN/Inf", "nan.bgeo", bgeo_file(nan_pts, true), "particle 1: non-finite"});
    c.push_back({"NaN/Inf", "infgz.bgeo", gzip(bgeo_file(inf_pts, false)), "particle 2: non-finite"});
    c.push_back({"NaN/Inf", "inf.ply", ply_file(inf_pts, "ascii", false), "vertex 2: non-finite"});
    c.push_back({"NaN/Inf", "nan.ply", ply_file(nan_pts, "binary_little_endian", true), "particle 1"});
    c.push_back({"NaN/Inf", "big.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nend_header\n0 -1e39 0\n",
                 "vertex 0: coordinate -1e+39 is beyond the float range (+-3.4e38)"});
    {
        std::string x(reinterpret_cast<const char*>(nan_pts.data()), nan_pts.size() * 4);
        c.push_back({"NaN/Inf", "nan.xyz", x, "offset 16: particle 1: non-finite"});
    }

    // --- zlib / gzip bombs and corruption
    {
        std::string z = make_vtu(pts, {"zlib", "appended", true});
        z[appended_start(z) + 72 + 3] ^= 0x55;  // header: 3 + 6 words of 8 bytes; then block 0
        c.push_back({"zlib", "badzlib.vtu", z, "bad zlib block 0 of the Points"});
        std::string t = make_vtu(pts, {"zlib", "appended", true});
        t.replace(appended_start(t) + 24, 8, le_bytes(std::uint64_t(100000)));  // block 0 claims 100 kB compressed
        c.push_back({"zlib", "bigblock.vtu", t, "truncated compressed block 0"});
        // a block that claims more output than deflate can make from its bytes
        std::string r = make_vtu(pts, {"zlib", "appended", true});
        r = replace_once(r, "NumberOfPoints=\"4\"", "NumberOfPoints=\"100000\"");
        r = replace_once(r, "<UnstructuredGrid>", "<UnstructuredGrid>" + std::string(3000, ' '));  // so the file could hold 2.4 MB
        r.replace(appended_start(r), 24, le_bytes(std::uint64_t(1)) + le_bytes(std::uint64_t(2400000)) + le_bytes(std::uint64_t(2400000)));
        c.push_back({"zlib", "ratio.vtu", r, "zlib block 0 of the Points claims 2.4 MB from"});
        // a real bomb: 2.4 MB of zeros in one block of about 2.4 kB; its header says 96 bytes
        const std::string zeros = zcompress(std::string(2400000, '\0'));
        std::string bomb = make_vtu(pts, {"zlib", "appended", true});
        const std::string payload = le_bytes(std::uint64_t(1)) + le_bytes(std::uint64_t(96)) + le_bytes(std::uint64_t(96)) +
                                    le_bytes(std::uint64_t(zeros.size())) + zeros;
        const auto u = appended_start(bomb);
        bomb.replace(u, bomb.find("\n</AppendedData>") - u, payload);
        c.push_back({"zlib", "bomb.vtu", bomb, "bad zlib block 0 of the Points"});
        std::string sizes = make_vtu(pts, {"zlib", "appended", true});
        sizes.replace(appended_start(sizes) + 16, 8, le_bytes(std::uint64_t(15)));  // last block size
        c.push_back({"zlib", "lastsize.vtu", sizes, "compressed data array holds a wrong size, expected 96 bytes for the Points"});
    }
    {
        std::string g = gzip(bgeo_plain);
        g[g.size() - 6] ^= 0x01;  // CRC32 of the trailer
        c.push_back({"zlib", "crc.bgeo", g, "bad gzip stream (incorrect data check)"});
        std::string d = gzip(bgeo_plain);
        for (std::size_t i = 12; i < 40; ++i) d[i] = static_cast<char>(0xff);
        c.push_back({"zlib", "deflate.bgeo", d, "bad gzip stream"});
        c.push_back({"zlib", "truncgz.bgeo", gzip(bgeo_plain).substr(0, 40), "truncated gzip stream"});
        // 50 MB of zeros in about 50 kB: rejected after inflating a few kB
        c.push_back({"zlib", "zeros.bgeo", gzip(std::string(50000000, '\0')), "expected magic 'BgeoV' after gunzip"});
        std::string head = bgeo_file({}, false);
        head.replace(9, 4, i32be(0x7fffffff));
        c.push_back({"zlib", "bombhead.bgeo", gzip(head + std::string(1000000, '\0')), "needs 34.4 GB but the file has"});
    }

    // --- wrong endianness flags
    c.push_back({"endianness", "bigflag.vtu", replace_once(make_vtu(pts, {"raw", "appended"}), "LittleEndian", "BigEndian"), "holds 6917529027641081856 bytes, expected 96"});
    c.push_back({"endianness", "bigflagz.vtu", replace_once(make_vtu(pts, {"zlib", "binary", true}), "LittleEndian", "BigEndian"), ""});
    c.push_back({"endianness", "littleflag.vtu", replace_once(make_vtu(pts, {"big", "appended", false, false, false, false, true}), "BigEndian", "LittleEndian"), "expected 96"});
    c.push_back({"endianness", "middle.vtu", replace_once(make_vtu(pts, {"raw", "appended"}), "LittleEndian", "MiddleEndian"), "unknown byte_order 'MiddleEndian'"});
    c.push_back({"endianness", "header16.vtu", replace_once(make_vtu(pts, {"raw", "appended"}), "UInt64", "UInt16"), "unsupported header_type 'UInt16'"});
    {
        // 0x0000807f is a tiny finite float; read with the other byte order it is +Inf
        float odd;
        const std::uint32_t bits = 0x0000807f;
        std::memcpy(&odd, &bits, 4);
        c.push_back({"endianness", "swapped.ply", replace_once(ply_file({odd, 0, 0}, "binary_little_endian", false), "binary_little_endian", "binary_big_endian"), "particle 0"});
    }

    // --- attribute arrays shorter than the point count, or missing
    {
        // binary SCALARS density cut to 3 values: the next keyword's bytes are read as data, then
        // VECTORS is not found where expected
        std::string s = vtk_attr_bin;
        const auto at = s.find("LOOKUP_TABLE default\n", s.find("POINT_DATA")) + 21;
        s.erase(at + 12, 4);
        c.push_back({"short attribute", "shortscalars.vtk", s, "", want});
        std::string a = vtk_attr_ascii;
        const auto lut = a.find("LOOKUP_TABLE default\n", a.find("POINT_DATA")) + 21;
        a.erase(lut, a.find(' ', lut) + 1 - lut);  // one value fewer
        c.push_back({"short attribute", "shortscalars2.vtk", a, "malformed number 'VECTORS'", want});
        std::vector<TestAttribute> three = {attrs[0], attrs[1], test_attribute("pressure", 1, 4, 0.5f)};
        std::string f = replace_once(vtk_with_data(pts, three, false, false), "pressure 1 4 float", "pressure 1 3 float");
        c.push_back({"short attribute", "shortfield.vtk", f, "FIELD array 'pressure' has 3 tuples, expected one per point (4)", {"pressure"}});
        c.push_back({"short attribute", "pointdata.vtk", replace_once(vtk_attr_bin, "POINT_DATA 4", "POINT_DATA 3"), "POINT_DATA 3 does not match POINTS 4", want});
        c.push_back({"short attribute", "truncattr.vtk", vtk_attr_bin.substr(0, vtk_attr_bin.size() - 10), "truncated binary data", want});
    }
    {
        std::string raw = make_vtu(pts, {"raw", "appended"}, attrs);
        const auto off = raw.find("Name=\"density\"");
        const auto o = std::stoul(raw.substr(raw.find("offset=\"", off) + 8));
        raw.replace(appended_start(raw) + o, 8, le_bytes(std::uint64_t(24)));
        c.push_back({"short attribute", "shortraw.vtu", raw, "holds 24 bytes, expected 32 for PointData 'density'", want});
        std::string ascii = make_vtu(pts, {"ascii", "ascii"}, attrs);
        const auto d = ascii.find(">", ascii.find("Name=\"density\"")) + 1;
        ascii.erase(d, ascii.find(' ', d) + 1 - d);
        c.push_back({"short attribute", "shortascii.vtu", ascii, "PointData 'density' holds 3 ascii values, expected 4", want});
        std::string b = make_vtu(pts, {"b64", "binary"}, attrs);
        const auto t = b.find("  ", b.find(">", b.find("Name=\"velocity\""))) + 2;
        b.erase(t + 20, 16);
        c.push_back({"short attribute", "shortb64.vtu", b, "truncated base64 data", want});
        std::string z = make_vtu(pts, {"zlib", "appended", true}, attrs);
        const auto zo = std::stoul(z.substr(z.find("offset=\"", z.find("Name=\"velocity\"")) + 8));
        z.replace(appended_start(z) + zo + 16, 8, le_bytes(std::uint64_t(8)));  // last block holds 8, not 16
        c.push_back({"short attribute", "shortzlib.vtu", z, "compressed data array holds a wrong size, expected 96 bytes for PointData 'velocity'", want});
        c.push_back({"short attribute", "selfclosing.vtu", replace_once(make_vtu(pts, {"b64", "binary"}, attrs), "Name=\"density\" NumberOfComponents=\"1\" format=\"binary\">", "Name=\"density\" NumberOfComponents=\"1\" format=\"binary\"/><x>"), "truncated base64 data", want});
    }
    c.push_back({"missing attribute", "missing.vtk", vtk_attr_bin, "no point attribute 'mass' (the file has: uv, density, velocity)", {"mass"}});
    c.push_back({"missing attribute", "missing.vtu", make_vtu(pts, {"zlib", "appended", true}, attrs), "no point attribute 'mass' (the file has: density, velocity)", {"mass"}});
    c.push_back({"missing attribute", "missing.bgeo", gzip(bgeo_plain), "no point attribute 'mass' (the file has: id, velocity, kind, density)", {"mass"}});
    c.push_back({"missing attribute", "missing.ply", ply_file(pts, "binary_big_endian", false, attrs), "no point attribute 'mass' (the file has: flag, z, x, y, density, velocity_x, velocity_y, velocity_z)", {"mass"}});
    c.push_back({"missing attribute", "missing.xyz", std::string(reinterpret_cast<const char*>(pts.data()), 48), "no point attribute 'mass' (the file has none)", {"mass"}});

    // --- truncated files (named cases; every cut point is swept in the next test)
    const std::string vtk_good = vtk_binary(pts, "4.2", "UNSTRUCTURED_GRID", false);
    c.push_back({"truncated", "truncated.vtk", vtk_good.substr(0, 100), "truncated binary data"});
    c.push_back({"truncated", "shortascii.vtk", vtk_ascii_head + "POINTS 2 float\n0 0 0 1\n", "line 5: truncated ASCII data: 6 values cannot fit in the 8 bytes left"});
    const std::string vtu_good = make_vtu(pts, {"raw zlib", "appended", true});
    c.push_back({"truncated", "truncated.vtu", vtu_good.substr(0, vtu_good.size() - 120), "truncated"});
    c.push_back({"truncated", "truncated.bgeo", gzip(bgeo_plain.substr(0, 150)), "truncated point data: 4 points of 40 bytes need 160 bytes, 20 bytes left"});
    c.push_back({"truncated", "header.bgeo", bgeo_plain.substr(0, 20), "offset 17: truncated header"});
    const std::string ply_good = ply_file(pts, "binary_big_endian", true);
    c.push_back({"truncated", "truncated.ply", ply_good.substr(0, ply_good.size() - 5), "truncated PLY data"});
    c.push_back({"truncated", "noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\n" + xyz_props, "PLY header has no end_header"});
    c.push_back({"truncated", "odd.xyz", std::string(13, '\0'), "size 13 bytes is not a multiple of 12"});
    return c;
}

/// Reads `file` with the case's attributes; returns the Error message (empty when it read).
std::string read_error(const std::string& file, const std::vector<std::string>& attributes) {
    ReadOptions o;
    o.attributes = attributes;
    try {
        read_particles(file, o);
    } catch (const trilevel::Error& e) {
        return e.what();
    }
    return {};
}

}  // namespace

TEST_CASE("hostile corpus: every case is one Error line naming the file and the problem", "[io][hostile]") {
    TempDir tmp;
    const auto cases = corpus();
    std::map<std::string, int> per_class;
    for (const auto& k : cases) {
        INFO(k.cls << ": " << k.name);
        const std::string f = tmp.file(k.name);
        if (k.bytes == "<dir>") std::filesystem::create_directories(f);
        else write_bytes(f, k.bytes);
        const std::string msg = read_error(f, k.attributes);
        INFO("message: " << msg);
        REQUIRE(!msg.empty());
        CHECK(msg.rfind(f + ": ", 0) == 0);
        CHECK(msg.find(k.what) != std::string::npos);
        CHECK(msg.find('\n') == std::string::npos);
        CHECK(msg.size() < 600);
        ++per_class[k.cls];
        std::filesystem::remove_all(f);
    }
    std::string summary;
    for (const auto& [cls, n] : per_class) summary += cls + ": " + std::to_string(n) + ", ";
    INFO(summary);
    CHECK(per_class.size() == 12);
    CHECK(cases.size() >= 120);
}

TEST_CASE("devices are refused before reading: a link to /dev/zero would never end", "[io][hostile]") {
    TempDir tmp;
    if (!std::filesystem::exists("/dev/zero")) return;
    std::filesystem::create_symlink("/dev/zero", tmp.path / "zero.vtk");
    REQUIRE_THROWS_WITH(read_particles(tmp.file("zero.vtk")), Catch::Contains("zero.vtk: is a device or socket, expected a file"));
    REQUIRE_THROWS_WITH(read_particles("/dev/null"), Catch::Contains("/dev/null: is a device or socket"));
}

namespace {

struct Sweep {
    std::string name;
    std::string bytes;
    std::vector<std::string> attributes;
    bool text = false;  ///< a cut inside the last number of a text file can shorten it silently
};

std::size_t differing(const std::vector<float>& a, const std::vector<float>& b) {
    std::size_t d = 0;
    for (std::size_t i = 0; i < a.size(); ++i) d += std::memcmp(&a[i], &b[i], 4) != 0;
    return d;
}

}  // namespace

// (.xyz has no header: a prefix of whole triplets is a valid smaller file, so it is not swept)
TEST_CASE("truncation sweep: every prefix of every format is an Error or yields the same particles", "[io][hostile]") {
    TempDir tmp;
    const auto pts = sample_points();
    const auto attrs = std::vector<TestAttribute>{test_attribute("density", 1, 4, 1000.0f), test_attribute("velocity", 3, 4, -2.0f)};
    const std::vector<std::string> want = {"density", "velocity"};
    std::vector<Sweep> files = {
        {"a.vtk", vtk_binary(pts, "4.2", "POLYDATA", false), {}},
        {"b.vtk", vtk_binary(pts, "5.1", "UNSTRUCTURED_GRID", true), {}},
        {"c.vtk", vtk_ascii(pts, "float"), {}, true},
        {"d.vtk", vtk_with_data(pts, attrs, true, false), want},
        {"e.vtk", vtk_with_data(pts, attrs, true, true), want},
        {"f.vtk", vtk_with_data(pts, attrs, false, true), want, true},
        {"a.bgeo", bgeo_file(pts, true), {"velocity", "density", "id"}},
        {"b.bgeo", gzip(bgeo_file(pts, true)), {"velocity", "density", "id"}},
        {"a.ply", ply_file(pts, "ascii", false, attrs), want, true},
        {"b.ply", ply_file(pts, "binary_little_endian", true, attrs), want},
        {"c.ply", ply_file(pts, "binary_big_endian", false, attrs), want},
    };
    for (const auto& v : vtu_variants()) files.push_back({"v.vtu", make_vtu(pts, v, attrs), want, v.format == "ascii"});
    // the prefixes go to the format readers in memory (read_particles adds only the file read):
    // some 17000 files through the file system would take most of a minute on a busy disk
    std::size_t cuts = 0, errors = 0;
    for (const auto& s : files) {
        const std::string f = tmp.file(s.name);
        write_bytes(f, s.bytes);
        ReadOptions o;
        o.attributes = s.attributes;
        const auto full = read_particles(f, o);
        REQUIRE(full.size() == 4);
        const auto ext = std::filesystem::path(s.name).extension().string();
        const auto reader = ext == ".vtk" ? trilevel::io::read_vtk : ext == ".vtu" ? trilevel::io::read_vtu
                          : ext == ".bgeo" ? trilevel::io::read_bgeo : trilevel::io::read_ply;
        for (std::size_t cut = 0; cut < s.bytes.size(); ++cut) {
            INFO(s.name << " cut at " << cut << " of " << s.bytes.size());
            const std::string prefix = s.bytes.substr(0, cut);
            ++cuts;
            try {
                const auto part = reader({f, prefix, s.attributes, false});
                // a prefix that reads must hold all the data: a binary file is then identical, a
                // text file may differ in its very last number only
                REQUIRE(part.positions.size() == full.positions.size());
                REQUIRE(part.attributes.size() == full.attributes.size());
                std::size_t d = differing(part.positions, full.positions);
                for (std::size_t a = 0; a < full.attributes.size(); ++a) {
                    REQUIRE(part.attributes[a].values.size() == full.attributes[a].values.size());
                    d += differing(part.attributes[a].values, full.attributes[a].values);
                }
                REQUIRE(d <= (s.text ? 1u : 0u));
            } catch (const trilevel::Error& e) {
                ++errors;
                const std::string msg = e.what();
                REQUIRE(msg.rfind(f + ": ", 0) == 0);
                REQUIRE(msg.find('\n') == std::string::npos);
            }
        }
    }
    INFO(cuts << " cuts, " << errors << " errors");
    CHECK(errors > cuts / 2);
}

TEST_CASE("CLI: hostile inputs end as one stderr line, a non-zero exit and no output file", "[cli][hostile]") {
    TempDir tmp;
    const auto cases = corpus();
    std::map<std::string, int> taken;
    const std::string out = tmp.file("out.ply");
    for (const auto& k : cases) {
        if (!k.attributes.empty() || taken[k.cls]++ >= 2) continue;  // two of each class (attributes: another helper's flag)
        INFO(k.cls << ": " << k.name);
        const std::string f = tmp.file(k.name);
        if (k.bytes == "<dir>") std::filesystem::create_directories(f);
        else write_bytes(f, k.bytes);
        const CliResult r = run_cli(tmp, "reconstruct '" + f + "' -r 0.025 -q -o '" + out + "'");
        const std::string& err = r.err;
        INFO("stderr: " << err);
        CHECK(r.code > 0);
        CHECK(err.rfind("trilevel: error: " + f + ": ", 0) == 0);
        CHECK(std::count(err.begin(), err.end(), '\n') == 1);
        CHECK(err.find(k.what) != std::string::npos);
        CHECK_FALSE(std::filesystem::exists(out));
        std::filesystem::remove_all(f);
    }
}

TEST_CASE("CLI: --drop-invalid drops NaN/Inf particles with one warning, all invalid is an error", "[cli][hostile]") {
    TempDir tmp;
    std::vector<float> block;  // 8 x 8 x 8 particles at spacing 2r
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j)
            for (int k = 0; k < 8; ++k) block.insert(block.end(), {i * 0.05f, j * 0.05f, k * 0.05f});
    std::vector<float> bad = block;
    bad.insert(bad.begin() + 3 * 100, {NAN, 0.1f, 0.1f});
    bad.insert(bad.begin() + 3 * 300, {0.1f, INFINITY, 0.1f});
    const std::string in = tmp.file("bad.xyz"), clean = tmp.file("clean.xyz");
    write_bytes(in, std::string(reinterpret_cast<const char*>(bad.data()), bad.size() * 4));
    write_bytes(clean, std::string(reinterpret_cast<const char*>(block.data()), block.size() * 4));
    auto run = [&](const std::string& input, const std::string& out, const std::string& flags) {
        return run_cli(tmp, "reconstruct '" + input + "' -r 0.025 " + flags + " -o '" + out + "'");
    };
    // without the flag: the error names the first bad particle
    const CliResult r0 = run(in, tmp.file("no.ply"), "");
    CHECK(r0.code != 0);
    CHECK(r0.err == "trilevel: error: " + in + ": offset 1200: particle 100: non-finite coordinate (NaN or Inf)\n");
    CHECK_FALSE(std::filesystem::exists(tmp.file("no.ply")));
    // with it: one warning line, and the mesh of the 512 valid particles, byte for byte
    const CliResult r1 = run(in, tmp.file("dropped.ply"), "--drop-invalid");
    REQUIRE(r1.code == 0);
    CHECK(r1.err == "warning: " + in + ": dropped 2 particles with NaN/Inf coordinates\n");
    CHECK(r1.out.find("particles: 512\n") != std::string::npos);
    const CliResult r2 = run(clean, tmp.file("clean.ply"), "--drop-invalid");
    REQUIRE(r2.code == 0);
    CHECK(r2.err.empty());
    const std::string a = slurp(tmp.file("dropped.ply")), b = slurp(tmp.file("clean.ply"));
    CHECK(a.size() > 1000);
    CHECK(a == b);
    // nothing valid: an error, no output
    const std::vector<float> all_bad = {NAN, 0, 0, 0, 0, -INFINITY};
    write_bytes(tmp.file("allbad.xyz"), std::string(reinterpret_cast<const char*>(all_bad.data()), all_bad.size() * 4));
    const CliResult r3 = run(tmp.file("allbad.xyz"), tmp.file("none.ply"), "--drop-invalid");
    CHECK(r3.code != 0);
    CHECK(r3.err == "trilevel: error: " + tmp.file("allbad.xyz") + ": no valid particles: all 2 have NaN/Inf coordinates\n");
    CHECK_FALSE(std::filesystem::exists(tmp.file("none.ply")));
}
