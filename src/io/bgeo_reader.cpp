// Houdini classic geometry (.bgeo, "BgeoV" version 5) as SPlisHSPlasH/Partio write it,
// gzip'd or plain: big-endian header, point attribute table, then one record per point
// holding P as x y z w (homogeneous, w = 1 in practice) and the other point attributes.
#include <zlib.h>

#include "io/io_common.hpp"
#include "io/particle_formats.hpp"

namespace trilevel::io {
namespace {

/// Inflates a gzip stream (possibly several members); deflate's ratio bounds the output.
std::string gunzip(const std::string& path, const std::string& in) {
    z_stream zs{};
    if (inflateInit2(&zs, 16 + MAX_WBITS) != Z_OK) fail(path, "cannot initialise zlib");
    std::string out;
    out.resize(std::max<std::size_t>(in.size() * 4, 1 << 16));
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
    zs.avail_in = static_cast<uInt>(in.size());  // files above 4 GiB are fed in pieces below
    std::size_t fed = in.size() > UINT32_MAX ? UINT32_MAX : in.size();
    zs.avail_in = static_cast<uInt>(fed);
    std::size_t produced = 0;
    for (;;) {
        if (produced == out.size()) out.resize(out.size() * 2);
        const std::size_t room = std::min<std::size_t>(out.size() - produced, UINT32_MAX);
        zs.next_out = reinterpret_cast<Bytef*>(out.data() + produced);
        zs.avail_out = static_cast<uInt>(room);
        const int rc = inflate(&zs, Z_NO_FLUSH);
        produced += room - zs.avail_out;
        if (zs.avail_in == 0 && fed < in.size()) {
            const std::size_t more = std::min<std::size_t>(in.size() - fed, UINT32_MAX);
            zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data() + fed));
            zs.avail_in = static_cast<uInt>(more);
            fed += more;
        }
        if (rc == Z_STREAM_END) {
            if (zs.avail_in == 0 && fed == in.size()) break;
            inflateReset(&zs);  // another gzip member follows
            continue;
        }
        if (rc != Z_OK && rc != Z_BUF_ERROR) {
            const std::string msg = zs.msg ? zs.msg : zError(rc);
            const std::size_t at = fed - zs.avail_in;
            inflateEnd(&zs);
            fail(path, "offset " + std::to_string(at) + ": bad gzip stream (" + msg + ")");
        }
        if (rc == Z_BUF_ERROR && zs.avail_in == 0 && fed == in.size()) {
            inflateEnd(&zs);
            fail(path, "offset " + std::to_string(in.size()) + ": truncated gzip stream");
        }
    }
    inflateEnd(&zs);
    out.resize(produced);
    return out;
}

/// Bounds-checked big-endian reads over the decompressed bytes.
struct BgeoCursor {
    const std::string& path;
    const std::string& data;
    std::size_t pos = 0;

    void need(std::size_t n, const char* what) const {
        if (data.size() - pos < n)
            fail(path, "offset " + std::to_string(pos) + " (uncompressed): truncated " + what);
    }
    std::int32_t i32(const char* what) { need(4, what); pos += 4; return load<std::int32_t>(data.data() + pos - 4, true); }
    std::uint16_t u16(const char* what) { need(2, what); pos += 2; return load<std::uint16_t>(data.data() + pos - 2, true); }
    void skip(std::size_t n, const char* what) { need(n, what); pos += n; }
};

/// Skips one attribute definition; returns its size in 32-bit words of a point record.
std::size_t skip_attribute(BgeoCursor& cur) {
    cur.skip(cur.u16("attribute name length"), "attribute name");
    const std::size_t size = cur.u16("attribute size");
    const std::size_t at = cur.pos;
    const std::int32_t type = cur.i32("attribute type");
    if (type == 0 || type == 1 || type == 5) {  // float, int, vector: `size` default values
        cur.skip(4 * size, "attribute defaults");
    } else if (type == 4) {  // indexed string: the string table
        const std::int32_t n = cur.i32("string table size");
        if (n < 0) fail(cur.path, "offset " + std::to_string(at) + " (uncompressed): negative string count");
        for (std::int32_t i = 0; i < n; ++i) cur.skip(cur.u16("string length"), "string");
    } else {
        fail(cur.path, "offset " + std::to_string(at) + " (uncompressed): unsupported attribute type " + std::to_string(type));
    }
    return size;
}

}  // namespace

std::vector<float> read_bgeo_points(const std::string& path, const std::string& file) {
    const bool gz = file.size() >= 2 && static_cast<unsigned char>(file[0]) == 0x1f && static_cast<unsigned char>(file[1]) == 0x8b;
    const std::string data = gz ? gunzip(path, file) : file;
    if (data.size() < 5 || data.compare(0, 5, "BgeoV") != 0)
        fail(path, "not a classic BGEO file: expected magic 'BgeoV'" + std::string(gz ? " after gunzip" : ""));
    BgeoCursor cur{path, data, 5};
    const std::int32_t version = cur.i32("header");
    if (version != 5) fail(path, "offset 5: BGEO version " + std::to_string(version) + " unsupported, expected 5");
    std::int32_t counts[8];
    for (auto& c : counts) c = cur.i32("header");
    const std::int32_t n = counts[0], attrs = counts[4];
    if (n < 0 || attrs < 0) fail(path, "offset 9: corrupt BGEO header (negative point or attribute count)");
    std::size_t stride = 4;  // P: x y z w
    for (std::int32_t a = 0; a < attrs; ++a) stride += skip_attribute(cur);
    const std::size_t record = stride * 4;
    if (static_cast<std::uint64_t>(n) > (data.size() - cur.pos) / record)
        fail(path, "offset " + std::to_string(cur.pos) + " (uncompressed): truncated point data: " + std::to_string(n) +
                       " points of " + std::to_string(record) + " bytes need " + std::to_string(std::uint64_t(n) * record) +
                       ", " + std::to_string(data.size() - cur.pos) + " left");
    std::vector<float> out(3 * static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i)
        for (std::size_t k = 0; k < 3; ++k) out[3 * i + k] = load<float>(data.data() + cur.pos + i * record + 4 * k, true);
    check_finite(path, out);
    return out;
}

}  // namespace trilevel::io
