// Houdini classic geometry (.bgeo, "BgeoV" version 5) as SPlisHSPlasH/Partio write it,
// gzip'd or plain: big-endian header, point attribute table, then one record per point
// holding P as x y z w (homogeneous, w = 1 in practice) and the other point attributes.
// A gzip'd file is inflated only as far as the reader needs, so that a header claiming more
// points than the compressed bytes could hold is an error before any large inflate. The point
// data itself is inflated in one call by libdeflate where the build has it (about twice zlib's
// speed: bench/RESULTS-implementation.md).
#include <algorithm>
#include <cmath>
#include <memory>

#include <zlib.h>
#ifdef TRILEVEL_HAVE_LIBDEFLATE
#include <libdeflate.h>
#endif

#include "io/io_common.hpp"
#include "io/particle_formats.hpp"

namespace trilevel::io {
namespace {

/// The (decompressed) bytes of a BGEO file, inflated on demand.
class BgeoBytes {
public:
    BgeoBytes(const std::string& path, const std::string& file) : path_(path), file_(file) {
        gz_ = file.size() >= 2 && static_cast<unsigned char>(file[0]) == 0x1f && static_cast<unsigned char>(file[1]) == 0x8b;
        if (!gz_) return;
        if (inflateInit2(&zs_, 16 + MAX_WBITS) != Z_OK) fail(path, "cannot initialise zlib");
        open_ = true;
    }
    ~BgeoBytes() {
        if (open_) inflateEnd(&zs_);
    }
    BgeoBytes(const BgeoBytes&) = delete;
    BgeoBytes& operator=(const BgeoBytes&) = delete;

    bool gzipped() const { return gz_; }
    /// Whether all was inflated in one piece: the file's bytes are no longer read.
    bool inflated_whole() const { return whole_size_ > 0; }
    const char* data() const { return inflated_whole() ? whole_bytes() : gz_ ? out_.data() : file_.data(); }
    std::size_t size() const { return inflated_whole() ? whole_size_ : gz_ ? out_.size() : file_.size(); }  ///< bytes available so far

    /// inflate_whole's buffer, handed over (read_bgeo makes it the positions); no bytes remain.
    std::vector<float> take_whole() {
        whole_size_ = 0;
        return std::move(whole_);
    }

    /// The most bytes the file can hold once decompressed: its size, or deflate's best ratio.
    std::uint64_t max_size() const { return gz_ ? max_inflated_size(file_.size()) : file_.size(); }

    /// Makes the first n bytes available; false when the data ends before (Error for bad gzip).
    bool ensure(std::uint64_t n) {
        if (!gz_) return n <= file_.size();
        if (inflated_whole()) return n <= whole_size_;
        if (n >= kWholeAt && inflate_whole(n)) return true;
        while (out_.size() < n && !ended_) {
            const std::size_t have = out_.size();
            const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(n, max_size()));
            out_.resize(std::max(want, have + 4096));
            const std::size_t got = inflate_into(out_.data() + have, out_.size() - have);
            out_.resize(have + got);
        }
        return out_.size() >= n;
    }

    /// Inflates what follows the bytes read (up to `limit` bytes, discarded) so that a corrupt
    /// stream or CRC is still an Error; stops quietly at the limit (data after the points).
    void drain(std::uint64_t limit) {
        std::vector<char> scratch(1 << 16);
        for (std::uint64_t done = 0; gz_ && !ended_ && done < limit;) done += inflate_into(scratch.data(), scratch.size());
    }

private:
    static constexpr std::uint64_t kWholeAt = 1 << 20;  ///< requests from this size on try inflate_whole

    /// The whole file in one libdeflate call, when it is one gzip member whose footer gives a size
    /// of at least the n bytes asked for. Anything else (several members, a wrong
    /// footer, a corrupt or truncated stream) is left to the zlib path, which words the errors.
    bool inflate_whole([[maybe_unused]] std::uint64_t n) {
#ifdef TRILEVEL_HAVE_LIBDEFLATE
        if (file_.size() < 18) return false;
        const std::uint64_t isize = load<std::uint32_t>(file_.data() + file_.size() - 4, false);  // size mod 2^32
        // At most twice what the points need: a footer claiming far more is left to zlib, which
        // inflates only the n bytes asked for.
        if (isize < n || isize > max_size() || isize > 2 * n + kWholeAt) return false;
        // Floats, so that the positions can take this buffer over (positions_in_place).
        std::vector<float> buf((std::size_t(isize) + sizeof(float) - 1) / sizeof(float));
        libdeflate_decompressor* d = libdeflate_alloc_decompressor();
        if (!d) return false;
        std::size_t in_used = 0, out_len = 0;
        const libdeflate_result rc =
            libdeflate_gzip_decompress_ex(d, file_.data(), file_.size(), buf.data(), isize, &in_used, &out_len);
        libdeflate_free_decompressor(d);
        if (rc != LIBDEFLATE_SUCCESS || in_used != file_.size() || out_len != isize) return false;
        whole_ = std::move(buf);
        whole_size_ = isize;
        ended_ = true;
        return true;
#else
        return false;
#endif
    }

    /// Inflates up to `room` bytes into dst; handles several gzip members and inputs over 4 GiB.
    std::size_t inflate_into(char* dst, std::size_t room) {
        zs_.next_out = reinterpret_cast<Bytef*>(dst);
        zs_.avail_out = static_cast<uInt>(std::min<std::size_t>(room, UINT32_MAX));
        const std::size_t start = zs_.avail_out;
        while (zs_.avail_out > 0 && !ended_) {
            if (zs_.avail_in == 0 && fed_ < file_.size()) {
                const std::size_t more = std::min<std::size_t>(file_.size() - fed_, UINT32_MAX);
                zs_.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(file_.data() + fed_));
                zs_.avail_in = static_cast<uInt>(more);
                fed_ += more;
            }
            const int rc = inflate(&zs_, Z_NO_FLUSH);
            if (rc == Z_STREAM_END) {
                if (zs_.avail_in == 0 && fed_ == file_.size()) ended_ = true;
                else inflateReset(&zs_);  // another gzip member follows
                continue;
            }
            if (rc == Z_BUF_ERROR && zs_.avail_in == 0 && fed_ == file_.size())
                fail(path_, "offset " + std::to_string(file_.size()) + ": truncated gzip stream");
            if (rc != Z_OK && rc != Z_BUF_ERROR)
                fail(path_, "offset " + std::to_string(fed_ - zs_.avail_in) + ": bad gzip stream (" +
                                (zs_.msg ? zs_.msg : zError(rc)) + ")");
        }
        return start - zs_.avail_out;
    }

    const std::string& path_;
    const std::string& file_;
    bool gz_ = false, open_ = false, ended_ = false;
    z_stream zs_{};
    std::size_t fed_ = 0;
    std::string out_;
    const char* whole_bytes() const { return reinterpret_cast<const char*>(whole_.data()); }

    std::vector<float> whole_;    ///< inflate_whole's result, when it succeeded
    std::size_t whole_size_ = 0;  ///< bytes of it (0: none)
};

/// Bounds-checked big-endian reads over the decompressed bytes.
struct BgeoCursor {
    const std::string& path;
    BgeoBytes& bytes;
    std::size_t pos = 0;

    std::string where() const { return "offset " + std::to_string(pos) + (bytes.gzipped() ? " (uncompressed)" : ""); }
    void need(std::uint64_t n, const char* what) {
        if (!bytes.ensure(pos + n)) fail(path, where() + ": truncated " + what);
    }
    std::int32_t i32(const char* what) { need(4, what); pos += 4; return load<std::int32_t>(bytes.data() + pos - 4, true); }
    std::uint16_t u16(const char* what) { need(2, what); pos += 2; return load<std::uint16_t>(bytes.data() + pos - 2, true); }
    void skip(std::size_t n, const char* what) { need(n, what); pos += n; }
    std::string str(std::size_t n, const char* what) { need(n, what); pos += n; return std::string(bytes.data() + pos - n, n); }
};

/// A point attribute: name, type (0 float, 1 int, 4 indexed string, 5 vector), size in 32-bit
/// words and word offset in the point record.
struct BgeoAttribute {
    std::string name;
    std::int32_t type = 0;
    std::size_t size = 0, offset = 0;
    std::size_t at = 0;  ///< file offset of the definition, for messages
};

/// Reads one attribute definition (skipping its defaults or string table).
BgeoAttribute read_attribute(BgeoCursor& cur, std::size_t offset) {
    BgeoAttribute a;
    a.at = cur.pos;
    a.name = cur.str(cur.u16("attribute name length"), "attribute name");
    a.size = cur.u16("attribute size");
    a.offset = offset;
    const std::string where = cur.where();
    a.type = cur.i32("attribute type");
    if (a.type == 0 || a.type == 1 || a.type == 5) {  // float, int, vector: `size` default values
        cur.skip(4 * a.size, "attribute defaults");
    } else if (a.type == 4) {  // indexed string: the string table
        const std::int32_t n = cur.i32("string table size");
        if (n < 0) fail(cur.path, where + ": negative string count " + std::to_string(n) + " for attribute '" + a.name + "'");
        for (std::int32_t i = 0; i < n; ++i) cur.skip(cur.u16("string length"), "string");
    } else {
        fail(cur.path, where + ": attribute '" + a.name + "' has unsupported type " + std::to_string(a.type) +
                           ", expected 0 (float), 1 (int), 4 (string) or 5 (vector)");
    }
    return a;
}

/// The requested attributes of n point records of `record` bytes starting at `base`.
void read_attributes(const std::string& path, const char* base, std::size_t n, std::size_t record,
                     const std::vector<BgeoAttribute>& table, AttributeSink& sink) {
    for (const auto& a : table) {
        const int index = sink.wanted(a.name);
        if (index < 0) continue;
        const std::string where = "offset " + std::to_string(a.at);
        if (a.type == 4) fail(path, where + ": attribute '" + a.name + "' holds strings, expected numbers");
        std::vector<float> v(n * a.size);
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t k = 0; k < a.size; ++k) {
                const char* p = base + i * record + 4 * (a.offset + k);
                v[i * a.size + k] = a.type == 1 ? static_cast<float>(load<std::int32_t>(p, true)) : load<float>(p, true);
            }
        sink.append(index, static_cast<int>(a.size), v, where);
    }
}

/// The point records of a BGEO file: P's x y z (big-endian floats) open each record.
struct PointRecords {
    const char* base;    ///< the first record
    std::size_t count;   ///< records
    std::size_t record;  ///< bytes a record (16 at least: P is x y z w)

    /// Coordinate k (0 x, 1 y, 2 z) of point i.
    float coordinate(std::size_t i, std::size_t k) const { return load<float>(base + i * record + 4 * k, true); }

    /// Index 3 i + k of the first coordinate that is NaN or infinite, SIZE_MAX when none is.
    std::size_t first_non_finite() const {
        for (std::size_t i = 0; i < count; ++i)
            for (std::size_t k = 0; k < 3; ++k)
                if (!std::isfinite(coordinate(i, k))) return 3 * i + k;
        return SIZE_MAX;
    }
    /// x y z of every point to `xyz` (3 count floats). `xyz` may be the buffer that holds the
    /// records, at or before `base`: point i's floats 3 i .. 3 i + 2 (bytes 12 i .. 12 i + 11) lie
    /// before its record (record >= 16) and after every record read before it, so each record is
    /// read before anything overwrites it.
    void copy_positions(float* xyz) const {
        for (std::size_t i = 0; i < count; ++i) {
            const float x = coordinate(i, 0), y = coordinate(i, 1), z = coordinate(i, 2);
            xyz[3 * i] = x;
            xyz[3 * i + 1] = y;
            xyz[3 * i + 2] = z;
        }
    }
};

/// The positions made from the inflated file that holds `points`, in its own buffer (moving a
/// vector keeps its storage, so `points` still lies in `inflated`). A x512 frame (17.7 M points)
/// then holds its 270 MiB of inflated bytes, then 202 MiB of positions, never both (and skips a
/// 202 MiB allocation); the records' other bytes, past the positions, go back to the system
/// (release_unused_capacity).
std::vector<float> positions_in_place(std::vector<float> inflated, const PointRecords& points) {
    points.copy_positions(inflated.data());
    inflated.resize(3 * points.count);
    release_unused_capacity(inflated);
    return inflated;
}

}  // namespace

ParticleSet read_bgeo(const ReadRequest& r) {
    const std::string& path = r.path;
    BgeoBytes bytes(path, r.data);
    BgeoCursor cur{path, bytes, 0};
    if (!bytes.ensure(5) || std::string_view(bytes.data(), 5) != "BgeoV")
        fail(path, "not a classic BGEO file: expected magic 'BgeoV'" + std::string(bytes.gzipped() ? " after gunzip" : ""));
    cur.pos = 5;
    const std::int32_t version = cur.i32("header");
    if (version != 5) fail(path, "offset 5: BGEO version " + std::to_string(version) + " unsupported, expected 5");
    std::int32_t counts[8];
    for (auto& c : counts) c = cur.i32("header");
    const std::int32_t n = counts[0], attrs = counts[4];
    if (n < 0 || attrs < 0)
        fail(path, "offset 9: corrupt BGEO header: negative " + std::string(n < 0 ? "point" : "point attribute") + " count " +
                       std::to_string(n < 0 ? n : attrs));
    // each definition takes 8 bytes at least (name length, size, type): bound the table first
    if (static_cast<std::uint64_t>(attrs) > (bytes.max_size() - std::min<std::uint64_t>(cur.pos, bytes.max_size())) / 8)
        fail(path, "offset 25: point attribute count " + std::to_string(attrs) + " needs at least " +
                       byte_size_text(8 * std::uint64_t(attrs)) + " but the file has " + byte_size_text(r.data.size()));
    std::vector<BgeoAttribute> table;
    std::size_t stride = 4;  // P: x y z w (32-bit words); each attribute adds at most 65535
    for (std::int32_t a = 0; a < attrs; ++a) {
        table.push_back(read_attribute(cur, stride));
        stride += table.back().size;
    }
    const std::uint64_t record = std::uint64_t(stride) * 4;
    const std::uint64_t room = bytes.max_size() > cur.pos ? bytes.max_size() - cur.pos : 0;
    if (static_cast<std::uint64_t>(n) > room / record) {
        const std::uint64_t need = static_cast<std::uint64_t>(n) * record;  // < 2^31 * 2^50: no overflow
        fail(path, cur.where() + ": point count " + std::to_string(n) + " of " + std::to_string(record) + " bytes needs " +
                       byte_size_text(need) + " but the file has " + byte_size_text(r.data.size()) +
                       (bytes.gzipped() ? " (at most " + byte_size_text(bytes.max_size()) + " inflated)" : ""));
    }
    const std::uint64_t need = static_cast<std::uint64_t>(n) * record;
    if (!bytes.ensure(cur.pos + need))
        fail(path, cur.where() + ": truncated point data: " + std::to_string(n) + " points of " + std::to_string(record) +
                       " bytes need " + byte_size_text(need) + ", " + byte_size_text(bytes.size() - cur.pos) + " left");
    if (r.releasable && bytes.inflated_whole()) std::string().swap(*r.releasable);  // before the positions
    const PointRecords points{bytes.data() + cur.pos, static_cast<std::size_t>(n), static_cast<std::size_t>(record)};
    if (!r.keep_invalid)
        if (const std::size_t v = points.first_non_finite(); v != SIZE_MAX)
            fail(path, "offset " + std::to_string(cur.pos + (v / 3) * record + 4 * (v % 3)) + (bytes.gzipped() ? " (uncompressed)" : "") +
                           ": particle " + std::to_string(v / 3) + ": non-finite coordinate (NaN or Inf)");
    AttributeSink sink(r);
    read_attributes(path, points.base, points.count, points.record, table, sink);  // before the records are overwritten
    ParticleSet set;
    if (bytes.inflated_whole()) {
        set.positions = positions_in_place(bytes.take_whole(), points);
    } else {
        set.positions.resize(3 * points.count);
        points.copy_positions(set.positions.data());
        bytes.drain(std::max<std::uint64_t>(need, 64 << 20));  // the CRC of the rest, unless it is huge
    }
    set.attributes = sink.finish(set.size());
    return set;
}

}  // namespace trilevel::io
