// VTK XML unstructured grid (.vtu): Points of every Piece, and the PointData arrays asked for,
// stored ascii, inline base64 (format="binary"), or appended (raw or base64), optionally
// zlib-compressed in blocks. Every size a header claims is checked against the bytes present
// (or, compressed, against deflate's best ratio) before anything is allocated or inflated.
// A small tag scanner stands in for an XML parser: only the tags we need are looked at.
#include <algorithm>
#include <climits>
#include <map>
#include <optional>

#include <zlib.h>

#include "io/io_common.hpp"
#include "io/particle_formats.hpp"

namespace trilevel::io {
namespace {

struct Tag {
    std::string name;
    std::map<std::string, std::string> attrs;
    std::size_t begin = 0, end = 0;  ///< offsets of '<' and one past '>'
    bool self_closing = false;

    std::string get(const std::string& key, const std::string& fallback = "") const {
        auto it = attrs.find(key);
        return it == attrs.end() ? fallback : it->second;
    }
};

/// The next start tag named `name` in xml[from, limit), nullopt when there is none.
std::optional<Tag> find_tag(const std::string& path, std::string_view xml, const std::string& name,
                            std::size_t from, std::size_t limit) {
    const std::string open = "<" + name;
    for (std::size_t p = xml.find(open, from); p != std::string_view::npos && p < limit; p = xml.find(open, p + 1)) {
        const std::size_t after = p + open.size();
        if (after < xml.size() && !std::isspace(static_cast<unsigned char>(xml[after])) && xml[after] != '>' &&
            xml[after] != '/')
            continue;  // a longer name, e.g. <PointsData
        Tag tag;
        tag.name = name;
        tag.begin = p;
        std::size_t i = after;
        for (;;) {
            while (i < xml.size() && std::isspace(static_cast<unsigned char>(xml[i]))) ++i;
            if (i >= xml.size()) fail(path, "offset " + std::to_string(p) + ": unterminated <" + name + "> tag");
            if (xml[i] == '>' || (xml[i] == '/' && i + 1 < xml.size() && xml[i + 1] == '>')) {
                tag.self_closing = xml[i] == '/';
                tag.end = i + (tag.self_closing ? 2 : 1);
                return tag;
            }
            const std::size_t eq = xml.find('=', i);
            if (eq == std::string_view::npos) fail(path, "offset " + std::to_string(i) + ": malformed attribute in <" + name + ">");
            std::string key(xml.substr(i, eq - i));
            while (!key.empty() && std::isspace(static_cast<unsigned char>(key.back()))) key.pop_back();
            std::size_t q = eq + 1;
            while (q < xml.size() && std::isspace(static_cast<unsigned char>(xml[q]))) ++q;
            if (q >= xml.size() || (xml[q] != '"' && xml[q] != '\''))
                fail(path, "offset " + std::to_string(q) + ": expected a quoted attribute value in <" + name + ">");
            const std::size_t close = xml.find(xml[q], q + 1);
            if (close == std::string_view::npos) fail(path, "offset " + std::to_string(q) + ": unterminated attribute value");
            tag.attrs[key] = std::string(xml.substr(q + 1, close - q - 1));
            i = close + 1;
        }
    }
    return std::nullopt;
}

int b64_value(char c) {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
}

std::size_t b64_chars(std::uint64_t bytes) { return 4 * ((bytes + 2) / 3); }

/// Decodes base64 text (a whole number of 4-character groups, '=' only at the end).
std::string b64_decode(const std::string& path, std::string_view text, std::size_t text_offset) {
    if (text.size() % 4 != 0) fail(path, "offset " + std::to_string(text_offset) + ": bad base64 data (length not a multiple of 4)");
    std::string out;
    out.reserve(text.size() / 4 * 3);
    for (std::size_t i = 0; i < text.size(); i += 4) {
        int v[4];
        int pad = 0;
        for (int k = 0; k < 4; ++k) {
            const char c = text[i + k];
            if (c == '=' && i + 4 == text.size() && k >= 2) { v[k] = 0; ++pad; continue; }
            v[k] = pad ? -1 : b64_value(c);
            if (v[k] < 0) fail(path, "offset " + std::to_string(text_offset + i + k) + ": bad base64 data");
        }
        const std::uint32_t w = (v[0] << 18) | (v[1] << 12) | (v[2] << 6) | v[3];
        out.push_back(static_cast<char>(w >> 16));
        if (pad < 2) out.push_back(static_cast<char>((w >> 8) & 0xff));
        if (pad < 1) out.push_back(static_cast<char>(w & 0xff));
    }
    return out;
}

std::optional<Scalar> vtu_type(const std::string& t) {
    static const std::map<std::string, Scalar> types = {
        {"Int8", Scalar::I8},   {"UInt8", Scalar::U8},   {"Int16", Scalar::I16},   {"UInt16", Scalar::U16},
        {"Int32", Scalar::I32}, {"UInt32", Scalar::U32}, {"Int64", Scalar::I64},   {"UInt64", Scalar::U64},
        {"Float32", Scalar::F32}, {"Float64", Scalar::F64}};
    auto it = types.find(t);
    return it == types.end() ? std::nullopt : std::optional<Scalar>(it->second);
}

/// Decodes one binary DataArray of a known byte size into its raw bytes.
class VtuDecoder {
public:
    VtuDecoder(const std::string& path, const Tag& root) : path_(path) {
        const std::string order = root.get("byte_order", "LittleEndian");
        if (order != "LittleEndian" && order != "BigEndian")
            fail(path, "offset " + std::to_string(root.begin) + ": unknown byte_order '" + order + "', expected LittleEndian or BigEndian");
        big_ = order == "BigEndian";
        const std::string ht = root.get("header_type", "UInt32");
        if (ht != "UInt32" && ht != "UInt64") fail(path, "unsupported header_type '" + ht + "', expected UInt32 or UInt64");
        hs_ = ht == "UInt32" ? 4 : 8;
        const std::string comp = root.get("compressor");
        if (!comp.empty() && comp != "vtkZLibDataCompressor")
            fail(path, "unsupported compressor '" + comp + "', expected vtkZLibDataCompressor");
        zlib_ = !comp.empty();
    }

    bool big_endian() const { return big_; }
    std::size_t header_bytes() const { return hs_; }  ///< 4 (UInt32) or 8 (UInt64)
    bool compressed() const { return zlib_; }

    /// Raw (not base64) header + payload at buf, `expected` bytes of array `what`; `at` is the
    /// file offset for messages.
    std::string raw(std::string_view buf, std::size_t at, std::uint64_t expected, const std::string& what) const {
        if (!zlib_) {
            const std::uint64_t n = header_word(buf, 0, at);
            check_plain_size(n, expected, at, what);
            if (buf.size() - hs_ < n)
                fail(path_, "offset " + std::to_string(at) + ": truncated appended data: " + what + " needs " +
                                byte_size_text(n) + ", " + byte_size_text(buf.size() - hs_) + " left");
            return std::string(buf.substr(hs_, n));
        }
        const std::uint64_t nb = header_word(buf, 0, at);
        check_block_count(nb, buf.size(), at);
        const std::size_t hbytes = (3 + nb) * hs_;
        if (buf.size() < hbytes) fail(path_, "offset " + std::to_string(at) + ": truncated compression header");
        return inflate_blocks(buf.substr(0, hbytes), buf.substr(hbytes), at, expected, what);
    }

    /// Base64 text holding header + payload, encoded jointly or separately (VTK does both).
    std::string base64(std::string_view text, std::size_t at, std::uint64_t expected, const std::string& what) const {
        const std::size_t first = b64_chars(zlib_ ? 3 * hs_ : hs_);
        if (text.size() < first) fail(path_, "offset " + std::to_string(at) + ": truncated base64 data");
        const std::string head = b64_decode(path_, text.substr(0, first), at);
        const std::uint64_t nb = zlib_ ? header_word(head, 0, at) : 0;
        if (zlib_) check_block_count(nb, text.size(), at);
        const std::uint64_t hbytes = zlib_ ? (3 + nb) * hs_ : hs_;
        const std::size_t hc = b64_chars(hbytes);
        if (text.size() < hc) fail(path_, "offset " + std::to_string(at) + ": truncated base64 data");
        const bool separate = hbytes % 3 == 0 || text[hc - 1] == '=';
        const std::string header = b64_decode(path_, text.substr(0, hc), at).substr(0, hbytes);
        std::uint64_t payload = zlib_ ? 0 : header_word(header, 0, at);
        if (!zlib_) check_plain_size(payload, expected, at, what);
        for (std::uint64_t b = 0; zlib_ && b < nb; ++b) {
            const std::uint64_t c = header_word(header, 3 + b, at);
            if (c > text.size() - payload)  // the base64 text holds fewer bytes than its characters
                fail(path_, "offset " + std::to_string(at) + ": compressed blocks claim more bytes than the data holds");
            payload += c;
        }
        const std::size_t start = separate ? hc : 0;
        const std::uint64_t chars = separate ? b64_chars(payload) : b64_chars(hbytes + payload);
        if (text.size() - start < chars) fail(path_, "offset " + std::to_string(at) + ": truncated base64 data");
        std::string body = b64_decode(path_, text.substr(start, chars), at + start);
        body = separate ? body.substr(0, payload) : body.substr(hbytes, payload);
        if (body.size() != payload) fail(path_, "offset " + std::to_string(at) + ": truncated base64 data");
        return zlib_ ? inflate_blocks(header, body, at, expected, what) : body;
    }

private:
    std::uint64_t header_word(std::string_view buf, std::uint64_t index, std::size_t at) const {
        if (buf.size() < (index + 1) * hs_) fail(path_, "offset " + std::to_string(at) + ": truncated data array header");
        return hs_ == 4 ? load<std::uint32_t>(buf.data() + index * 4, big_) : load<std::uint64_t>(buf.data() + index * 8, big_);
    }

    void check_plain_size(std::uint64_t n, std::uint64_t expected, std::size_t at, const std::string& what) const {
        if (n != expected)
            fail(path_, "offset " + std::to_string(at) + ": data array holds " + std::to_string(n) + " bytes, expected " +
                            std::to_string(expected) + " for " + what);
    }

    void check_block_count(std::uint64_t nb, std::size_t available, std::size_t at) const {
        if (nb > available / hs_) fail(path_, "offset " + std::to_string(at) + ": compression header claims " + std::to_string(nb) + " blocks, more than the file holds");
    }

    /// header: nblocks, block size, last block size, compressed sizes; payload: the blocks.
    /// Every block's claimed size is checked (present, and within deflate's 1032:1 ratio of its
    /// compressed size) before the output is allocated and anything is inflated.
    std::string inflate_blocks(std::string_view header, std::string_view payload, std::size_t at,
                               std::uint64_t expected, const std::string& what) const {
        const std::uint64_t nb = header_word(header, 0, at), bs = header_word(header, 1, at);
        std::uint64_t last = header_word(header, 2, at);
        if (nb > 0 && last == 0) last = bs;
        const std::uint64_t total = nb == 0 ? 0 : (nb - 1) * bs + last;
        if (nb > 0 && ((bs == 0) || (nb - 1) > expected / bs || total != expected || last > bs))
            fail(path_, "offset " + std::to_string(at) + ": compressed data array holds a wrong size, expected " +
                            std::to_string(expected) + " bytes for " + what);
        if (nb == 0 && expected != 0) fail(path_, "offset " + std::to_string(at) + ": compressed data array is empty");
        std::uint64_t in = 0;
        for (std::uint64_t b = 0; b < nb; ++b) {
            const std::uint64_t csize = header_word(header, 3 + b, at);
            const std::uint64_t usize = b + 1 == nb ? last : bs;
            if (csize > payload.size() - in)
                fail(path_, "offset " + std::to_string(at) + ": truncated compressed block " + std::to_string(b) + " of " + what);
            if (usize > max_inflated_size(csize))
                fail(path_, "offset " + std::to_string(at) + ": zlib block " + std::to_string(b) + " of " + what + " claims " +
                                byte_size_text(usize) + " from " + byte_size_text(csize) + ", beyond zlib's 1032:1 ratio");
            if (usize > ULONG_MAX) fail(path_, "offset " + std::to_string(at) + ": zlib block too large for this zlib");
            in += csize;
        }
        std::string out(expected, '\0');
        std::size_t done = 0;
        in = 0;
        for (std::uint64_t b = 0; b < nb; ++b) {
            const std::uint64_t csize = header_word(header, 3 + b, at);
            const std::uint64_t usize = b + 1 == nb ? last : bs;
            uLongf len = static_cast<uLongf>(usize);
            const int rc = uncompress(reinterpret_cast<Bytef*>(out.data() + done), &len,
                                      reinterpret_cast<const Bytef*>(payload.data() + in), static_cast<uLong>(csize));
            if (rc != Z_OK || len != usize)
                fail(path_, "offset " + std::to_string(at) + ": bad zlib block " + std::to_string(b) + " of " + what + " (" +
                                (rc == Z_OK ? "wrong size" : zError(rc)) + ")");
            in += csize;
            done += usize;
        }
        return out;
    }

    const std::string& path_;
    bool big_ = false, zlib_ = false;
    std::size_t hs_ = 4;
};

struct Appended {
    std::string_view data;  ///< bytes after the '_' marker
    std::size_t offset = 0; ///< file offset of data
    bool base64 = false;
};

std::optional<Appended> find_appended(const std::string& path, const std::string& file, std::size_t& xml_end) {
    xml_end = file.size();
    const std::size_t i = file.find("<AppendedData");
    if (i == std::string::npos) return std::nullopt;
    auto tag = find_tag(path, file, "AppendedData", i, i + 1);
    if (!tag) fail(path, "offset " + std::to_string(i) + ": malformed <AppendedData> tag");
    const std::size_t u = file.find('_', tag->end);
    if (u == std::string::npos) fail(path, "offset " + std::to_string(tag->end) + ": AppendedData without the '_' marker");
    std::size_t end = file.rfind("</AppendedData>");
    if (end == std::string::npos || end < u) end = file.size();  // tolerate a cut-off closing tag; sizes catch truncation
    const std::string enc = tag->get("encoding", "raw");
    if (enc != "raw" && enc != "base64") fail(path, "offset " + std::to_string(i) + ": unknown AppendedData encoding '" + enc + "'");
    xml_end = i;
    return Appended{std::string_view(file).substr(u + 1, end - u - 1), u + 1, enc == "base64"};
}

std::string strip_ws(std::string_view s) {
    std::string out;
    out.reserve(s.size());
    for (char c : s)
        if (!std::isspace(static_cast<unsigned char>(c))) out.push_back(c);
    return out;
}

/// The text content of a DataArray: up to </DataArray>, without nested elements such as the
/// <InformationKey> blocks ParaView writes (whose <Value>s are not array data).
std::string inline_text(std::string_view xml, const Tag& array) {
    if (array.self_closing) return {};
    std::string out;
    std::size_t i = array.end;
    for (;;) {
        const std::size_t lt = xml.find('<', i);
        out.append(xml.substr(i, (lt == std::string_view::npos ? xml.size() : lt) - i));
        if (lt == std::string_view::npos || xml.compare(lt, 12, "</DataArray>") == 0) return out;
        std::size_t name_end = lt + 1;
        while (name_end < xml.size() && !std::isspace(static_cast<unsigned char>(xml[name_end])) && xml[name_end] != '>' &&
               xml[name_end] != '/')
            ++name_end;
        const std::string name(xml.substr(lt + 1, name_end - lt - 1));
        const std::size_t gt = xml.find('>', lt);
        if (gt == std::string_view::npos) return out;
        if (name.empty() || name[0] == '/' || xml[gt - 1] == '/') { i = gt + 1; continue; }  // a stray or empty element
        const std::size_t close = xml.find("</" + name + ">", gt);
        i = close == std::string_view::npos ? gt + 1 : close + name.size() + 3;
    }
}

/// Where a reader finds the arrays of one file.
struct VtuContext {
    const std::string& path;
    const std::string& file;
    const VtuDecoder& dec;
    const std::optional<Appended>& app;
    std::vector<std::uint64_t> appended_offsets;  ///< of every appended DataArray, sorted
};

/// The offsets of the appended DataArrays in `xml`, sorted. Unparsable offsets are left out, and
/// the scan ends at a malformed tag: the arrays the reader needs report their own faults, and a
/// fault in an array it skips must not fail the file.
std::vector<std::uint64_t> appended_offsets(const std::string& path, std::string_view xml) {
    std::vector<std::uint64_t> out;
    try {
        for (auto a = find_tag(path, xml, "DataArray", 0, xml.size()); a; a = find_tag(path, xml, "DataArray", a->end, xml.size())) {
            std::uint64_t off;
            if (a->get("format", "ascii") == "appended" && parse_u64(a->get("offset", "0"), off)) out.push_back(off);
        }
    } catch (const Error&) {
    }
    std::sort(out.begin(), out.end());
    return out;
}

/// A raw, uncompressed appended block is its size header and its bytes, so it ends where the next
/// block (or the appended data) begins. A file whose header_type names the other header width
/// passes every size check with UInt32 declared over 64-bit headers (the low word is the size)
/// while each value is read 4 bytes early. So a block whose header, read in the other width, gives
/// its size and which then ends exactly where the next block begins (and not so in the declared
/// width) is an error naming the header_type. Padding or trailing bytes after a block do not
/// match: the other width's reading includes data bytes and gives another size.
void check_header_type(const VtuContext& c, std::uint64_t off, std::uint64_t bytes, const std::string& at) {
    const std::uint64_t hs = c.dec.header_bytes(), other = hs == 4 ? 8 : 4;
    const std::string_view data = c.app->data;
    if (data.size() - off < other) return;
    const std::uint64_t other_size = other == 8 ? load<std::uint64_t>(data.data() + off, c.dec.big_endian())
                                                : load<std::uint32_t>(data.data() + off, c.dec.big_endian());
    if (other_size != bytes) return;
    const auto next = std::upper_bound(c.appended_offsets.begin(), c.appended_offsets.end(), off);
    std::uint64_t end = data.size();
    if (next != c.appended_offsets.end()) end = *next;
    else
        while (end > off && std::isspace(static_cast<unsigned char>(data[end - 1]))) --end;
    if (off + hs + bytes != end && off + other + bytes == end)
        fail(c.path, at + "header_type=\"UInt" + std::to_string(8 * hs) + "\", but the appended block at offset " +
                         std::to_string(off) + " has a " + std::to_string(8 * other) +
                         "-bit size header (it ends where the next block begins only so); the file's header_type is wrong");
}

/// The ascii values of an array: exactly `count` numbers; non-finite ones are an Error when
/// `coords` and finite_only (positions), kept as they are otherwise.
std::vector<float> ascii_array(const std::string& path, std::string_view text, std::size_t at, std::uint64_t count,
                               const std::string& what, bool coords, bool finite_only) {
    const auto tokens = split_ws(text);
    if (tokens.size() != count)
        fail(path, "offset " + std::to_string(at) + ": " + what + " holds " + std::to_string(tokens.size()) +
                       " ascii values, expected " + std::to_string(count));
    std::vector<float> out(count);
    for (std::size_t i = 0; i < count; ++i) {
        double v;
        if (!parse_double(tokens[i], v))
            fail(path, "offset " + std::to_string(at) + ": " + what + ": malformed number '" + std::string(tokens[i].substr(0, 40)) + "'");
        // the location text is built only for a value that fails (to_float_checked then throws)
        out[i] = coords && finite_only && !finite_float(v)
                     ? to_float_checked(path, v, i, "offset " + std::to_string(tokens[i].data() - text.data() + at) + ": ")
                     : narrow_to_float(v);
    }
    return out;
}

/// One DataArray of `tuples` x `comps` values as floats, whatever its format and encoding.
/// `what` names it in messages; coordinates (coords) reject NaN/Inf unless keep_invalid.
std::vector<float> read_data_array(const VtuContext& c, const Tag& array, std::uint64_t tuples, std::uint64_t comps,
                                   const std::string& what, bool coords, bool keep_invalid) {
    const std::string at = "offset " + std::to_string(array.begin) + ": ";
    const auto type = vtu_type(array.get("type"));
    if (!type) fail(c.path, at + "unsupported type '" + array.get("type") + "' for " + what + ", expected Int8..UInt64, Float32 or Float64");
    const std::uint64_t count = mul_checked(c.path, at + what, tuples, comps, "size");
    const std::size_t ts = scalar_size(*type);
    // the largest array a file of this size could hold even at zlib's best ratio (1032:1)
    if (count > (max_inflated_size(c.file.size()) + 1024) / ts)
        fail(c.path, at + what + ": NumberOfPoints=" + std::to_string(tuples) + " x " + std::to_string(comps) + " x " +
                         std::to_string(ts) + " bytes need " + byte_size_text(count > UINT64_MAX / ts ? UINT64_MAX : count * ts) +
                         ", more than a file of " + byte_size_text(c.file.size()) + " can hold even compressed");
    const std::uint64_t bytes = count * ts;
    const std::string format = array.get("format", "ascii");
    std::string raw;
    if (format == "ascii") return ascii_array(c.path, inline_text(c.file, array), array.end, count, what, coords, !keep_invalid);
    if (format == "binary") {
        raw = c.dec.base64(strip_ws(inline_text(c.file, array)), array.end, bytes, what);
    } else if (format == "appended") {
        if (!c.app) fail(c.path, at + "appended DataArray but no AppendedData section");
        std::uint64_t off;
        if (!parse_u64(array.get("offset", "0"), off)) fail(c.path, at + "bad DataArray offset '" + array.get("offset") + "'");
        if (off >= c.app->data.size())
            fail(c.path, at + "DataArray offset " + std::to_string(off) + " lies beyond the appended data (" +
                             std::to_string(c.app->data.size()) + " bytes)");
        if (!c.app->base64 && !c.dec.compressed()) check_header_type(c, off, bytes, at + what + ": ");
        raw = c.app->base64 ? c.dec.base64(c.app->data.substr(off), c.app->offset + off, bytes, what)
                            : c.dec.raw(c.app->data.substr(off), c.app->offset + off, bytes, what);
    } else {
        fail(c.path, at + "unknown DataArray format '" + format + "', expected ascii, binary or appended");
    }
    if (coords) return convert_coords(c.path, raw.data(), count, *type, c.dec.big_endian(), !keep_invalid, {SIZE_MAX, at + what});
    return convert_values(raw.data(), count, *type, c.dec.big_endian());
}

/// The requested PointData arrays of a piece of n points, appended to the sink.
void read_point_data(const VtuContext& c, std::string_view xml, std::size_t from, std::size_t piece_end,
                     std::uint64_t n, AttributeSink& sink) {
    const auto pd = find_tag(c.path, xml, "PointData", from, piece_end);
    if (!pd || pd->self_closing) return;
    std::size_t end = xml.find("</PointData>", pd->end);
    if (end == std::string_view::npos || end > piece_end) end = piece_end;
    for (auto a = find_tag(c.path, xml, "DataArray", pd->end, end); a; a = find_tag(c.path, xml, "DataArray", a->end, end)) {
        const int index = sink.wanted(a->get("Name"));
        if (index < 0) continue;
        const std::string what = "PointData '" + a->get("Name") + "'";
        std::uint64_t comps;
        if (!parse_u64(a->get("NumberOfComponents", "1"), comps) || (comps != 1 && comps != 3))
            fail(c.path, "offset " + std::to_string(a->begin) + ": " + what + " has NumberOfComponents=\"" +
                             a->get("NumberOfComponents") + "\", expected 1 or 3");
        sink.append(index, static_cast<int>(comps), read_data_array(c, *a, n, comps, what, false, false),
                    "offset " + std::to_string(a->begin));
    }
}

}  // namespace

ParticleSet read_vtu(const ReadRequest& r) {
    const std::string& path = r.path;
    const std::string& file = r.data;
    std::size_t xml_end;
    const auto app = find_appended(path, file, xml_end);
    const std::string_view xml = std::string_view(file).substr(0, xml_end);
    const auto root = find_tag(path, xml, "VTKFile", 0, xml.size());
    if (!root) fail(path, "not a VTK XML file: no <VTKFile> tag");
    const VtuDecoder dec(path, *root);
    const VtuContext ctx{path, file, dec, app, app ? appended_offsets(path, xml) : std::vector<std::uint64_t>{}};
    AttributeSink sink(r);
    ParticleSet set;
    bool any = false;
    for (auto piece = find_tag(path, xml, "Piece", root->end, xml.size()); piece;
         piece = find_tag(path, xml, "Piece", piece->end, xml.size())) {
        const std::string at = "offset " + std::to_string(piece->begin) + ": ";
        std::uint64_t n;
        if (!parse_u64(piece->get("NumberOfPoints", "0"), n)) fail(path, at + "bad NumberOfPoints '" + piece->get("NumberOfPoints") + "'");
        std::size_t piece_end = xml.find("</Piece>", piece->end);
        if (piece_end == std::string_view::npos) piece_end = xml.size();
        const auto points = find_tag(path, xml, "Points", piece->end, piece_end);
        const auto array = points ? find_tag(path, xml, "DataArray", points->end, piece_end) : std::nullopt;
        if (!array) {
            if (n) fail(path, at + "Piece with NumberOfPoints=" + std::to_string(n) + " has no <Points><DataArray>");
            continue;
        }
        if (array->get("NumberOfComponents", "3") != "3")
            fail(path, "offset " + std::to_string(array->begin) + ": Points must have NumberOfComponents=\"3\"");
        const auto pts = read_data_array(ctx, *array, n, 3, "the Points", true, r.keep_invalid);
        set.positions.insert(set.positions.end(), pts.begin(), pts.end());
        sink.next_piece();
        if (!r.attributes.empty()) read_point_data(ctx, xml, piece->end, piece_end, n, sink);
        any = true;
    }
    if (!any) fail(path, "no <Piece> with <Points> found");
    set.attributes = sink.finish(set.size());
    return set;
}

}  // namespace trilevel::io
