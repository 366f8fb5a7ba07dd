// VTK XML unstructured grid (.vtu): Points of every Piece, stored ascii, inline base64
// (format="binary"), or appended (raw or base64), optionally zlib-compressed in blocks.
// A small tag scanner stands in for an XML parser: only the tags we need are looked at.
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
        big_ = root.get("byte_order", "LittleEndian") == "BigEndian";
        const std::string ht = root.get("header_type", "UInt32");
        if (ht != "UInt32" && ht != "UInt64") fail(path, "unsupported header_type '" + ht + "', expected UInt32 or UInt64");
        hs_ = ht == "UInt32" ? 4 : 8;
        const std::string comp = root.get("compressor");
        if (!comp.empty() && comp != "vtkZLibDataCompressor")
            fail(path, "unsupported compressor '" + comp + "', expected vtkZLibDataCompressor");
        zlib_ = !comp.empty();
    }

    bool big_endian() const { return big_; }

    /// Raw (not base64) header + payload at buf; `at` is the file offset for messages.
    std::string raw(std::string_view buf, std::size_t at, std::uint64_t expected) const {
        if (!zlib_) {
            const std::uint64_t n = header_word(buf, 0, at);
            check_plain_size(n, expected, at);
            if (buf.size() - hs_ < n) fail(path_, "offset " + std::to_string(at) + ": truncated appended data");
            return std::string(buf.substr(hs_, n));
        }
        const std::uint64_t nb = header_word(buf, 0, at);
        check_block_count(nb, buf.size(), at);
        const std::size_t hbytes = (3 + nb) * hs_;
        if (buf.size() < hbytes) fail(path_, "offset " + std::to_string(at) + ": truncated compression header");
        return inflate_blocks(buf.substr(0, hbytes), buf.substr(hbytes), at, expected);
    }

    /// Base64 text holding header + payload, encoded jointly or separately (VTK does both).
    std::string base64(std::string_view text, std::size_t at, std::uint64_t expected) const {
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
        if (!zlib_) check_plain_size(payload, expected, at);
        for (std::uint64_t b = 0; zlib_ && b < nb; ++b) {
            const std::uint64_t c = header_word(header, 3 + b, at);
            if (c > text.size()) fail(path_, "offset " + std::to_string(at) + ": compressed block larger than the data");
            payload += c;
        }
        const std::size_t start = separate ? hc : 0;
        const std::uint64_t chars = separate ? b64_chars(payload) : b64_chars(hbytes + payload);
        if (text.size() - start < chars) fail(path_, "offset " + std::to_string(at) + ": truncated base64 data");
        std::string body = b64_decode(path_, text.substr(start, chars), at + start);
        body = separate ? body.substr(0, payload) : body.substr(hbytes, payload);
        if (body.size() != payload) fail(path_, "offset " + std::to_string(at) + ": truncated base64 data");
        return zlib_ ? inflate_blocks(header, body, at, expected) : body;
    }

private:
    std::uint64_t header_word(std::string_view buf, std::uint64_t index, std::size_t at) const {
        if (buf.size() < (index + 1) * hs_) fail(path_, "offset " + std::to_string(at) + ": truncated data array header");
        return hs_ == 4 ? load<std::uint32_t>(buf.data() + index * 4, big_) : load<std::uint64_t>(buf.data() + index * 8, big_);
    }

    void check_plain_size(std::uint64_t n, std::uint64_t expected, std::size_t at) const {
        if (n != expected)
            fail(path_, "offset " + std::to_string(at) + ": data array holds " + std::to_string(n) + " bytes, expected " +
                            std::to_string(expected) + " for the Points");
    }

    void check_block_count(std::uint64_t nb, std::size_t available, std::size_t at) const {
        if (nb > available / hs_) fail(path_, "offset " + std::to_string(at) + ": compression header claims " + std::to_string(nb) + " blocks, more than the file holds");
    }

    /// header: nblocks, block size, last block size, compressed sizes; payload: the blocks.
    std::string inflate_blocks(std::string_view header, std::string_view payload, std::size_t at,
                               std::uint64_t expected) const {
        const std::uint64_t nb = header_word(header, 0, at), bs = header_word(header, 1, at);
        std::uint64_t last = header_word(header, 2, at);
        if (nb > 0 && last == 0) last = bs;
        const std::uint64_t total = nb == 0 ? 0 : (nb - 1) * bs + last;
        if (nb > 0 && ((bs == 0) || (nb - 1) > expected / bs || total != expected || last > bs))
            fail(path_, "offset " + std::to_string(at) + ": compressed data array holds a wrong size, expected " + std::to_string(expected) + " bytes for the Points");
        if (nb == 0 && expected != 0) fail(path_, "offset " + std::to_string(at) + ": compressed data array is empty");
        std::string out(expected, '\0');
        std::size_t in = 0, done = 0;
        for (std::uint64_t b = 0; b < nb; ++b) {
            const std::uint64_t csize = header_word(header, 3 + b, at);
            const std::uint64_t usize = b + 1 == nb ? last : bs;
            if (csize > payload.size() - in) fail(path_, "offset " + std::to_string(at) + ": truncated compressed block " + std::to_string(b));
            uLongf len = static_cast<uLongf>(usize);
            const int rc = uncompress(reinterpret_cast<Bytef*>(out.data() + done), &len,
                                      reinterpret_cast<const Bytef*>(payload.data() + in), static_cast<uLong>(csize));
            if (rc != Z_OK || len != usize)
                fail(path_, "offset " + std::to_string(at) + ": bad zlib block " + std::to_string(b) + " (" + (rc == Z_OK ? "wrong size" : zError(rc)) + ")");
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

std::vector<float> ascii_array(const std::string& path, std::string_view text, std::size_t at, std::uint64_t count) {
    const auto tokens = split_ws(text);
    if (tokens.size() != count)
        fail(path, "offset " + std::to_string(at) + ": ascii Points hold " + std::to_string(tokens.size()) +
                       " values, expected " + std::to_string(count));
    std::vector<float> out(count);
    for (std::size_t i = 0; i < count; ++i) {
        double v;
        if (!parse_double(tokens[i], v))
            fail(path, "offset " + std::to_string(tokens[i].data() - text.data() + at) + ": malformed number '" + std::string(tokens[i].substr(0, 40)) + "'");
        out[i] = to_float_checked(path, v, i);
    }
    return out;
}

/// The Points DataArray of one piece holding n points.
std::vector<float> read_piece_points(const std::string& path, const std::string& file, const Tag& array,
                                     std::uint64_t n, const VtuDecoder& dec, const std::optional<Appended>& app) {
    const std::string at = "offset " + std::to_string(array.begin) + ": ";
    const auto type = vtu_type(array.get("type"));
    if (!type) fail(path, at + "unsupported Points type '" + array.get("type") + "', expected Float32 or Float64");
    if (array.get("NumberOfComponents", "3") != "3") fail(path, at + "Points must have NumberOfComponents=\"3\"");
    const std::size_t ts = scalar_size(*type);
    // the largest array a file of this size could hold even at zlib's best ratio (about 1032:1)
    if (n > (std::uint64_t(file.size()) * 1040 + 1024) / (3 * ts))
        fail(path, at + "NumberOfPoints=" + std::to_string(n) + " cannot fit in a file of " + std::to_string(file.size()) + " bytes");
    const std::uint64_t bytes = n * 3 * ts;
    const std::string format = array.get("format", "ascii");
    const std::size_t text_end = array.self_closing ? array.end : file.find('<', array.end);
    const std::string_view inline_text = std::string_view(file).substr(array.end, (text_end == std::string::npos ? file.size() : text_end) - array.end);
    std::string raw;
    if (format == "ascii") return ascii_array(path, inline_text, array.end, 3 * n);
    if (format == "binary") {
        raw = dec.base64(strip_ws(inline_text), array.end, bytes);
    } else if (format == "appended") {
        if (!app) fail(path, at + "appended DataArray but no AppendedData section");
        std::uint64_t off;
        if (!parse_u64(array.get("offset", "0"), off)) fail(path, at + "bad DataArray offset '" + array.get("offset") + "'");
        if (off >= app->data.size()) fail(path, at + "DataArray offset " + std::to_string(off) + " lies beyond the appended data");
        raw = app->base64 ? dec.base64(app->data.substr(off), app->offset + off, bytes)
                          : dec.raw(app->data.substr(off), app->offset + off, bytes);
    } else {
        fail(path, at + "unknown DataArray format '" + format + "', expected ascii, binary or appended");
    }
    return convert_coords(path, raw.data(), 3 * n, *type, dec.big_endian());
}

}  // namespace

std::vector<float> read_vtu_points(const std::string& path, const std::string& file) {
    std::size_t xml_end;
    const auto app = find_appended(path, file, xml_end);
    const std::string_view xml = std::string_view(file).substr(0, xml_end);
    const auto root = find_tag(path, xml, "VTKFile", 0, xml.size());
    if (!root) fail(path, "not a VTK XML file: no <VTKFile> tag");
    const VtuDecoder dec(path, *root);
    std::vector<float> out;
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
        const auto pts = read_piece_points(path, file, *array, n, dec, app);
        out.insert(out.end(), pts.begin(), pts.end());
        any = true;
    }
    if (!any) fail(path, "no <Piece> with <Points> found");
    return out;
}

}  // namespace trilevel::io
