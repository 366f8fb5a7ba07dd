// PLY (.ply): ascii, binary_little_endian, binary_big_endian. Reads vertex x, y, z of any
// numeric type and the vertex properties asked for as attributes; other vertex properties and
// other elements (also list properties) are skipped.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>

#include "io/io_common.hpp"
#include "io/particle_formats.hpp"
#include "io/ply_format.hpp"

namespace trilevel::io {
namespace {

std::optional<Scalar> ply_type(std::string_view t) {
    if (t == "char" || t == "int8") return Scalar::I8;
    if (t == "uchar" || t == "uint8") return Scalar::U8;
    if (t == "short" || t == "int16") return Scalar::I16;
    if (t == "ushort" || t == "uint16") return Scalar::U16;
    if (t == "int" || t == "int32") return Scalar::I32;
    if (t == "uint" || t == "uint32") return Scalar::U32;
    if (t == "float" || t == "float32") return Scalar::F32;
    if (t == "double" || t == "float64") return Scalar::F64;
    return std::nullopt;
}

void header_line(const std::string& path, std::size_t line_no, std::string_view line, PlyHeader& h, bool& have_format) {
    const auto t = split_ws(line);
    auto bad = [&](const std::string& what) {
        fail(path, "line " + std::to_string(line_no) + ": " + what + ", found '" + std::string(line.substr(0, 60)) + "'");
    };
    if (t.empty() || t[0] == "comment" || t[0] == "obj_info") return;
    if (t[0] == "format") {
        if (t.size() < 2) bad("expected format ascii|binary_little_endian|binary_big_endian 1.0");
        if (t[1] == "ascii") h.format = PlyHeader::Ascii;
        else if (t[1] == "binary_little_endian") h.format = PlyHeader::BinaryLE;
        else if (t[1] == "binary_big_endian") h.format = PlyHeader::BinaryBE;
        else bad("expected format ascii|binary_little_endian|binary_big_endian 1.0");
        have_format = true;
    } else if (t[0] == "element") {
        std::uint64_t n = 0;  // (bad() does not return; clang cannot tell)
        if (t.size() < 3 || !parse_u64(t[2], n)) bad("expected element <name> <count>");
        h.elements.push_back({std::string(t[1]), n, {}});
    } else if (t[0] == "property") {
        if (h.elements.empty()) bad("property before any element");
        PlyProperty p;
        if (t.size() >= 5 && t[1] == "list") {
            p.list_count = ply_type(t[2]);
            const auto vt = ply_type(t[3]);
            if (!p.list_count || !vt || *p.list_count == Scalar::F32 || *p.list_count == Scalar::F64)
                bad("expected property list <integer type> <type> <name>");
            p.type = *vt;
            p.name = std::string(t[4]);
        } else {
            const auto vt = t.size() >= 3 ? ply_type(t[1]) : std::nullopt;
            if (!vt) bad("expected property <type> <name>");
            p.type = *vt;
            p.name = std::string(t[2]);
        }
        h.elements.back().props.push_back(p);
    } else {
        bad("unknown PLY header keyword");
    }
}

}  // namespace

PlyHeader parse_ply_header(const std::string& path, const std::string& data) {
    if (data.compare(0, 3, "ply") != 0 || (data.size() > 3 && data[3] != '\n' && data[3] != '\r'))
        fail(path, "line 1: not a PLY file: expected 'ply'");
    PlyHeader h;
    bool have_format = false;
    std::size_t pos = data.find('\n') + 1, line_no = 1;
    for (;;) {
        if (pos == 0 || pos >= data.size()) fail(path, "line " + std::to_string(line_no) + ": PLY header has no end_header");
        std::size_t nl = data.find('\n', pos);
        if (nl == std::string::npos) nl = data.size();
        std::string_view line(data.data() + pos, nl - pos);
        ++line_no;
        pos = nl + 1;
        const auto t = split_ws(line);
        if (!t.empty() && t[0] == "end_header") break;
        header_line(path, line_no, line, h, have_format);
    }
    if (!have_format) fail(path, "PLY header has no format line");
    h.body = std::min(pos, data.size());
    h.header_lines = line_no;
    return h;
}

namespace {

/// Byte offset of each property in a fixed-size binary record.
std::size_t record_size(const PlyElement& e) {
    std::size_t s = 0;
    for (const auto& p : e.props) s += scalar_size(p.type);
    return s;
}

struct BinaryWalker {
    const std::string& path;
    const std::string& data;
    bool big;
    std::size_t pos;

    void need(std::uint64_t n) const {
        if (data.size() - pos < n) fail(path, "offset " + std::to_string(pos) + ": truncated PLY data");
    }
    /// Skips a whole element; fixed-size records are skipped at once.
    void skip(const PlyElement& e) {
        if (!e.has_list()) {
            const std::size_t rec = record_size(e);
            if (rec && e.count > (data.size() - pos) / rec) need(UINT64_MAX);
            pos += e.count * rec;
            return;
        }
        for (std::uint64_t i = 0; i < e.count; ++i)
            for (const auto& p : e.props) skip_property(p);
    }
    void skip_property(const PlyProperty& p) {
        if (!p.list_count) { need(scalar_size(p.type)); pos += scalar_size(p.type); return; }
        need(scalar_size(*p.list_count));
        const double k = load_scalar(data.data() + pos, *p.list_count, big);
        pos += scalar_size(*p.list_count);
        if (k < 0) fail(path, "offset " + std::to_string(pos) + ": negative list length");
        const std::uint64_t bytes = static_cast<std::uint64_t>(k) * scalar_size(p.type);
        need(bytes);
        pos += bytes;
    }
};

/// Where each vertex property goes: a position coordinate, an attribute component, or nowhere.
struct VertexSlot {
    std::vector<float>* dst = nullptr;  ///< null: skipped
    std::size_t stride = 0, comp = 0;
    bool coord = false;
};

/// The slots of the vertex properties: x, y, z into positions, requested attributes (a scalar
/// property `name`, or a triplet name_x/name_y/name_z or namex/namey/namez) into `attrs`.
std::vector<VertexSlot> vertex_slots(const std::string& path, const PlyElement& v, const ReadRequest& r,
                                     std::vector<float>& positions, std::vector<ParticleAttribute>& attrs) {
    std::vector<VertexSlot> slots(v.props.size());
    auto find = [&](const std::string& name) -> int {
        for (std::size_t k = 0; k < v.props.size(); ++k)
            if (v.props[k].name == name && !v.props[k].list_count) return static_cast<int>(k);
        return -1;
    };
    for (std::size_t c = 0; c < 3; ++c) {
        const int k = find(std::string(1, char('x' + c)));
        if (k < 0) fail(path, "PLY vertex element lacks property x, y or z");
        slots[k] = {&positions, 3, c, true};
    }
    attrs.reserve(r.attributes.size());  // slots point into attrs: no reallocation after this
    for (const auto& name : r.attributes) {
        int k[3] = {find(name), -1, -1};
        int comps = 1;
        if (k[0] < 0)
            for (const std::string sep : {"_", ""}) {
                for (std::size_t c = 0; c < 3; ++c) k[c] = find(name + sep + char('x' + c));
                if (k[0] >= 0 && k[1] >= 0 && k[2] >= 0) { comps = 3; break; }
            }
        if (k[0] < 0 || (comps == 3 && (k[1] < 0 || k[2] < 0))) {
            std::vector<std::string> names;
            for (const auto& p : v.props) if (!p.list_count) names.push_back(p.name);
            missing_attribute(path, name, names);
        }
        attrs.push_back({name, comps, {}});
        for (int c = 0; c < comps; ++c) {
            if (slots[k[c]].dst)
                fail(path, "attribute '" + name + "': property '" + v.props[k[c]].name + "' is already read as " +
                               (slots[k[c]].coord ? "a coordinate" : "another attribute"));
            slots[k[c]] = {&attrs.back().values, std::size_t(comps), std::size_t(c), false};
        }
    }
    return slots;
}

/// Reads the vertex element into positions and the attribute values (already sized).
void read_binary_vertices(const std::string& path, const std::string& data, const PlyHeader& h, std::size_t vi,
                          std::vector<VertexSlot>& slots, bool keep_invalid) {
    BinaryWalker w{path, data, h.format == PlyHeader::BinaryBE, h.body};
    for (std::size_t e = 0; e < vi; ++e) w.skip(h.elements[e]);
    const PlyElement& v = h.elements[vi];
    std::size_t min_rec = 0;  // the smallest a record can be: bounds the count before allocating
    for (const auto& p : v.props) min_rec += scalar_size(p.list_count ? *p.list_count : p.type);
    if (v.count > (data.size() - w.pos) / min_rec)
        fail(path, "offset " + std::to_string(w.pos) + ": truncated PLY data: " + std::to_string(v.count) + " vertices of at least " +
                       std::to_string(min_rec) + " bytes cannot fit in the " + byte_size_text(data.size() - w.pos) + " left");
    for (auto& s : slots) if (s.dst && s.comp == 0) s.dst->resize(s.stride * v.count);
    for (std::uint64_t i = 0; i < v.count; ++i) {
        for (std::size_t k = 0; k < v.props.size(); ++k) {
            const PlyProperty& p = v.props[k];
            const VertexSlot& s = slots[k];
            if (s.dst) {
                w.need(scalar_size(p.type));
                const double x = load_scalar(data.data() + w.pos, p.type, w.big);
                // the location text is built only for a value that fails (to_float_checked then throws)
                (*s.dst)[s.stride * i + s.comp] =
                    s.coord && !keep_invalid && !finite_float(x)
                        ? to_float_checked(path, x, 3 * i + s.comp, "offset " + std::to_string(w.pos) + ": ")
                        : narrow_to_float(x);
            }
            w.skip_property(p);
        }
    }
}

/// ASCII body: tokens, with the line number kept for messages.
struct AsciiWalker {
    const std::string& path;
    const std::string& data;
    std::size_t pos, line;

    std::string_view token() {
        while (pos < data.size() && std::isspace(static_cast<unsigned char>(data[pos]))) if (data[pos++] == '\n') ++line;
        const std::size_t s = pos;
        while (pos < data.size() && !std::isspace(static_cast<unsigned char>(data[pos]))) ++pos;
        if (pos == s) fail(path, "line " + std::to_string(line) + ": truncated PLY data");
        return std::string_view(data.data() + s, pos - s);
    }
    double number() {
        const auto t = token();
        double v;
        if (!parse_double(t, v)) fail(path, "line " + std::to_string(line) + ": malformed number '" + std::string(t.substr(0, 40)) + "'");
        return v;
    }
    void skip_property(const PlyProperty& p) {
        if (!p.list_count) { token(); return; }
        const double k = number();
        // every list entry takes two bytes at least: a longer list cannot be in the file
        if (k < 0 || k != std::floor(k) || k > double(data.size() - pos) / 2 + 1)
            fail(path, "line " + std::to_string(line) + ": bad list length");
        for (std::uint64_t j = 0; j < static_cast<std::uint64_t>(k); ++j) token();
    }
};

void read_ascii_vertices(const std::string& path, const std::string& data, const PlyHeader& h, std::size_t vi,
                         std::vector<VertexSlot>& slots, bool keep_invalid) {
    AsciiWalker w{path, data, h.body, h.header_lines + 1};
    for (std::size_t e = 0; e < vi; ++e)
        for (std::uint64_t i = 0; !h.elements[e].props.empty() && i < h.elements[e].count; ++i)
            for (const auto& p : h.elements[e].props) w.skip_property(p);
    const PlyElement& v = h.elements[vi];
    // each vertex needs at least 2 bytes per property: bound the count before allocating
    if (v.count > (data.size() - w.pos) / (2 * v.props.size()) + 1)
        fail(path, "line " + std::to_string(w.line) + ": truncated PLY data: " + std::to_string(v.count) +
                       " vertices cannot fit in the " + byte_size_text(data.size() - w.pos) + " left");
    for (auto& s : slots) if (s.dst && s.comp == 0) s.dst->resize(s.stride * v.count);
    for (std::uint64_t i = 0; i < v.count; ++i)
        for (std::size_t k = 0; k < v.props.size(); ++k) {
            const VertexSlot& s = slots[k];
            if (!s.dst) { w.skip_property(v.props[k]); continue; }
            const double x = w.number();
            if (s.coord && !keep_invalid && !finite_float(x))
                fail(path, "line " + std::to_string(w.line) + ": vertex " + std::to_string(i) + ": " + coordinate_problem(x));
            (*s.dst)[s.stride * i + s.comp] = narrow_to_float(x);
        }
}

}  // namespace

ParticleSet read_ply(const ReadRequest& r) {
    const std::string& path = r.path;
    const PlyHeader h = parse_ply_header(path, r.data);
    std::size_t vi = h.elements.size();
    for (std::size_t e = 0; e < h.elements.size(); ++e) if (h.elements[e].name == "vertex") { vi = e; break; }
    if (vi == h.elements.size()) fail(path, "PLY header has no 'element vertex'");
    ParticleSet set;
    auto slots = vertex_slots(path, h.elements[vi], r, set.positions, set.attributes);
    if (h.format != PlyHeader::Ascii) read_binary_vertices(path, r.data, h, vi, slots, r.keep_invalid);
    else read_ascii_vertices(path, r.data, h, vi, slots, r.keep_invalid);
    return set;
}

PlyValueReader::PlyValueReader(const std::string& path, const std::string& data, const PlyHeader& h)
    : path_(path), data_(data), ascii_(h.format == PlyHeader::Ascii), big_(h.format == PlyHeader::BinaryBE),
      pos_(h.body), line_(h.header_lines + 1) {}

double PlyValueReader::next(Scalar t) {
    if (!ascii_) {
        if (data_.size() - pos_ < scalar_size(t)) fail(path_, "offset " + std::to_string(pos_) + ": truncated PLY data");
        pos_ += scalar_size(t);
        return load_scalar(data_.data() + pos_ - scalar_size(t), t, big_);
    }
    while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) if (data_[pos_++] == '\n') ++line_;
    const std::size_t s = pos_;
    while (pos_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
    if (pos_ == s) fail(path_, "line " + std::to_string(line_) + ": truncated PLY data");
    double v;
    if (!parse_double(std::string_view(data_.data() + s, pos_ - s), v))
        fail(path_, "line " + std::to_string(line_) + ": malformed number '" + data_.substr(s, std::min<std::size_t>(pos_ - s, 40)) + "'");
    return v;
}

std::uint64_t PlyValueReader::list_length(Scalar t) {
    const double k = next(t);
    if (k < 0 || k != std::floor(k) || k > double(data_.size())) fail(path_, where() + ": bad list length");
    return static_cast<std::uint64_t>(k);
}

void PlyValueReader::skip(const PlyProperty& p) {
    const std::uint64_t k = p.list_count ? list_length(*p.list_count) : 1;
    for (std::uint64_t j = 0; j < k; ++j) next(p.type);
}

std::string PlyValueReader::where() const {
    return ascii_ ? "line " + std::to_string(line_) : "offset " + std::to_string(pos_);
}

std::size_t PlyValueReader::left() const { return data_.size() - pos_; }

}  // namespace trilevel::io
