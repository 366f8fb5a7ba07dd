// Legacy VTK (.vtk): ASCII or BINARY (big-endian), versions 2.0-5.1, any dataset type with POINTS.
// FIELD and METADATA blocks before POINTS are skipped. When attributes are asked for, the sections
// after POINTS are walked too (cells, POINT_DATA / CELL_DATA arrays) and the named point arrays
// (SCALARS, VECTORS, NORMALS, FIELD arrays with one tuple per point) are read.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>

#include "io/io_common.hpp"
#include "io/particle_formats.hpp"

namespace trilevel::io {
namespace {

std::optional<Scalar> vtk_type(std::string_view name) {
    const std::string t = upper(name);
    if (t == "FLOAT" || t == "VTKTYPEFLOAT32") return Scalar::F32;
    if (t == "DOUBLE" || t == "VTKTYPEFLOAT64") return Scalar::F64;
    if (t == "CHAR" || t == "VTKTYPEINT8") return Scalar::I8;
    if (t == "UNSIGNED_CHAR" || t == "VTKTYPEUINT8") return Scalar::U8;
    if (t == "SHORT" || t == "VTKTYPEINT16") return Scalar::I16;
    if (t == "UNSIGNED_SHORT" || t == "VTKTYPEUINT16") return Scalar::U16;
    if (t == "INT" || t == "VTKTYPEINT32") return Scalar::I32;
    if (t == "UNSIGNED_INT" || t == "VTKTYPEUINT32") return Scalar::U32;
    if (t == "LONG" || t == "VTKTYPEINT64" || t == "VTKIDTYPE") return Scalar::I64;
    if (t == "UNSIGNED_LONG" || t == "VTKTYPEUINT64") return Scalar::U64;
    return std::nullopt;
}

/// Walks the file line by line (keywords) and value by value (array data), counting lines.
class VtkCursor {
public:
    VtkCursor(const std::string& path, const std::string& data) : path_(path), data_(data) {}

    /// The next line, trimmed; nullopt at the end of the file.
    std::optional<std::string_view> raw_line() {
        if (pos_ >= data_.size()) return std::nullopt;
        std::size_t nl = data_.find('\n', pos_);
        if (nl == std::string::npos) nl = data_.size();
        std::string_view line(data_.data() + pos_, nl - pos_);
        pos_ = nl + 1;
        err_line_ = ++line_;
        while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.remove_suffix(1);
        while (!line.empty() && std::isspace(static_cast<unsigned char>(line.front()))) line.remove_prefix(1);
        return line;
    }

    /// The next non-empty line; nullopt at the end.
    std::optional<std::string_view> line() {
        for (;;) {
            auto l = raw_line();
            if (!l || !l->empty()) return l;
        }
    }

    /// The cursor state, to look at a line and go back (an optional LOOKUP_TABLE line).
    struct Mark { std::size_t pos, line, err_line; };
    Mark mark() const { return {pos_, line_, err_line_}; }
    void reset(const Mark& m) { pos_ = m.pos; line_ = m.line; err_line_ = m.err_line; }

    /// Error at the line of the last line or token read.
    [[noreturn]] void error(const std::string& what) const { fail(path_, "line " + std::to_string(err_line_) + ": " + what); }
    [[noreturn]] void error_at(const std::string& what) const { fail(path_, "offset " + std::to_string(pos_) + ": " + what); }

    /// Reads `count` coordinates of type t (binary big-endian or ASCII) as floats; NaN/Inf are an
    /// Error unless keep_invalid.
    std::vector<float> read_coords(std::uint64_t count, Scalar t, bool binary, bool keep_invalid) {
        return binary ? read_binary(count, t, !keep_invalid) : read_ascii(count, !keep_invalid);
    }

    /// Reads `count` values of type t as floats, whatever they hold (attribute arrays).
    std::vector<float> read_values(std::uint64_t count, Scalar t, bool binary) {
        return binary ? read_binary(count, t, false) : read_ascii(count, false);
    }

    /// Skips `count` values (binary or ASCII) without converting them.
    void skip_array(std::uint64_t count, Scalar t, bool binary) {
        if (binary) {
            check_binary_size(count, t);
            advance(count * scalar_size(t));
            return;
        }
        for (std::uint64_t i = 0; i < count; ++i)
            if (next_token().empty()) error("truncated ASCII data: found " + std::to_string(i) + " of " + std::to_string(count) + " values");
    }

    /// Reads `count` integers (binary big-endian or ASCII), e.g. polygon connectivity.
    std::vector<std::int64_t> read_ints(std::uint64_t count, Scalar t, bool binary) {
        if (binary) {
            check_binary_size(count, t);
            std::vector<std::int64_t> out(count);
            for (std::uint64_t i = 0; i < count; ++i) {
                const double v = load_scalar(data_.data() + pos_ + i * scalar_size(t), t, true);
                if (!is_int64(v)) error_at("integer value is not whole or out of range");
                out[i] = static_cast<std::int64_t>(v);
            }
            advance(count * scalar_size(t));
            return out;
        }
        check_ascii_size(count);
        std::vector<std::int64_t> out(count);
        for (std::uint64_t i = 0; i < count; ++i) {
            const std::string_view tok = next_token();
            double v;
            if (tok.empty()) error("truncated ASCII data: found " + std::to_string(i) + " of " + std::to_string(count) + " values");
            if (!parse_double(tok, v) || !is_int64(v)) error("malformed integer '" + std::string(tok.substr(0, 40)) + "'");
            out[i] = static_cast<std::int64_t>(v);
        }
        return out;
    }

private:
    /// A whole number that an int64 holds exactly: checked before the cast, which would overflow.
    static bool is_int64(double v) { return v == std::floor(v) && v >= -0x1p63 && v < 0x1p63; }

    std::uint64_t left() const { return data_.size() - std::min<std::size_t>(pos_, data_.size()); }

    /// Moves past `bytes` of binary data, counting the newline bytes in it so that line numbers
    /// in later messages stay those a text editor shows.
    void advance(std::uint64_t bytes) {
        line_ += static_cast<std::size_t>(std::count(data_.data() + pos_, data_.data() + pos_ + bytes, '\n'));
        pos_ += bytes;
    }

    void check_binary_size(std::uint64_t count, Scalar t) const {
        if (count > left() / scalar_size(t))
            error_at("truncated binary data: " + std::to_string(count) + " values of " + std::to_string(scalar_size(t)) +
                     " bytes need " + byte_size_text(count > UINT64_MAX / scalar_size(t) ? UINT64_MAX : count * scalar_size(t)) +
                     ", only " + byte_size_text(left()) + " left in the file");
    }

    /// Every ASCII value takes at least two bytes (a digit and a separator): bound before allocating.
    void check_ascii_size(std::uint64_t count) const {
        if (count > left() / 2 + 1)
            error("truncated ASCII data: " + std::to_string(count) + " values cannot fit in the " +
                  byte_size_text(left()) + " left in the file");
    }

    std::vector<float> read_binary(std::uint64_t count, Scalar t, bool finite_only) {
        check_binary_size(count, t);
        auto out = convert_coords(path_, data_.data() + pos_, count, t, true, finite_only, {pos_, {}});
        advance(count * scalar_size(t));
        return out;
    }

    std::string_view next_token() {
        while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) {
            if (data_[pos_] == '\n') ++line_;
            ++pos_;
        }
        err_line_ = line_ + 1;  // line_ counts the newlines before pos_
        const std::size_t start = pos_;
        while (pos_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
        return std::string_view(data_.data() + start, pos_ - start);
    }

    std::vector<float> read_ascii(std::uint64_t count, bool finite_only) {
        check_ascii_size(count);
        std::vector<float> out(count);
        for (std::uint64_t i = 0; i < count; ++i) {
            const std::string_view tok = next_token();
            if (tok.empty()) error("truncated ASCII data: found " + std::to_string(i) + " of " + std::to_string(count) + " values");
            double v;
            if (!parse_double(tok, v)) error("malformed number '" + std::string(tok.substr(0, 40)) + "'");
            if (finite_only && !finite_float(v))
                error("particle " + std::to_string(i / 3) + ": " + coordinate_problem(v, tok));
            out[i] = narrow_to_float(v);
        }
        return out;
    }

    const std::string& path_;
    const std::string& data_;
    std::size_t pos_ = 0;
    std::size_t line_ = 0;      ///< newlines consumed so far
    std::size_t err_line_ = 0;  ///< line of the last line or token read
};

bool read_header(VtkCursor& cur) {
    auto first = cur.raw_line();
    if (!first || upper(first->substr(0, 14)) != "# VTK DATAFILE")
        cur.error("not a legacy VTK file: expected '# vtk DataFile Version x.y'");
    if (!cur.raw_line()) cur.error("expected a title line");
    auto mode = cur.line();
    const std::string m = mode ? upper(*mode) : std::string();
    if (m != "ASCII" && m != "BINARY") cur.error("expected ASCII or BINARY, found '" + std::string(mode.value_or("")) + "'");
    return m == "BINARY";
}

std::uint64_t parse_count(VtkCursor& cur, std::string_view tok, const char* what) {
    std::uint64_t n;
    if (!parse_u64(tok, n)) cur.error(std::string("expected ") + what + ", found '" + std::string(tok) + "'");
    return n;
}

void skip_metadata(VtkCursor& cur) {
    for (auto l = cur.raw_line(); l && !l->empty(); l = cur.raw_line()) {
    }
}

/// FIELD <name> <narrays>, then per array: <name> <ncomp> <ntuples> <type> and its values.
void skip_field(VtkCursor& cur, const std::vector<std::string_view>& head, bool binary) {
    if (head.size() < 3) cur.error("expected FIELD <name> <number of arrays>");
    const std::uint64_t arrays = parse_count(cur, head[2], "FIELD <name> <number of arrays>");
    for (std::uint64_t a = 0; a < arrays; ++a) {
        auto l = cur.line();
        const auto t = l ? split_ws(*l) : std::vector<std::string_view>{};
        if (t.size() < 4) cur.error("expected <array name> <components> <tuples> <type> in FIELD");
        const std::uint64_t comps = parse_count(cur, t[1], "a component count");
        const std::uint64_t tuples = parse_count(cur, t[2], "a tuple count");
        const auto type = vtk_type(t[3]);
        if (!type) cur.error("unsupported FIELD array type '" + std::string(t[3]) + "'");
        if (comps != 0 && tuples > UINT64_MAX / comps) cur.error("FIELD array size overflows");
        cur.skip_array(comps * tuples, *type, binary);
    }
}

/// Reads up to and including the POINTS section.
std::vector<float> read_points_section(VtkCursor& cur, bool binary, bool keep_invalid) {
    for (;;) {
        auto l = cur.line();
        if (!l) cur.error("end of file before POINTS: expected POINTS <n> <type>");
        const auto t = split_ws(*l);
        const std::string kw = upper(t[0]);
        if (kw == "DATASET" || kw == "DIMENSIONS" || kw == "ORIGIN" || kw == "SPACING") continue;
        if (kw == "METADATA") { skip_metadata(cur); continue; }
        if (kw == "FIELD") { skip_field(cur, t, binary); continue; }
        if (kw != "POINTS" || t.size() < 3) cur.error("expected POINTS <n> <type>, found '" + std::string(l->substr(0, 60)) + "'");
        const std::uint64_t n = parse_count(cur, t[1], "POINTS <n> <type>");
        const auto type = vtk_type(t[2]);
        if (!type) cur.error("unsupported POINTS type '" + std::string(t[2]) + "', expected float or double");
        if (n > UINT64_MAX / 3) cur.error("POINTS count " + std::to_string(n) + " is impossible");
        return cur.read_coords(3 * n, *type, binary, keep_invalid);
    }
}

/// After binary POINTS, what follows must be the next section's keyword line, or nothing: binary
/// coordinates cannot tell a POINTS count larger than the points written, which reads the start of
/// the next section as coordinates. (ASCII coordinates meet the keyword as a malformed number.)
void require_section_after_binary_points(VtkCursor& cur) {
    static constexpr std::string_view kSections[] = {"CELLS", "VERTICES", "LINES", "POLYGONS", "TRIANGLE_STRIPS",
                                                     "OFFSETS", "CONNECTIVITY", "CELL_TYPES", "POINT_DATA",
                                                     "CELL_DATA", "FIELD", "METADATA"};
    const auto m = cur.mark();
    const auto l = cur.line();
    if (!l) return;
    const std::string kw = upper(split_ws(*l)[0]);
    if (std::find(std::begin(kSections), std::end(kSections), kw) != std::end(kSections)) {
        cur.reset(m);
        return;
    }
    const std::string_view head = l->substr(0, 40);
    const bool text = std::all_of(head.begin(), head.end(), [](unsigned char c) { return c >= 0x20 && c < 0x7f; });
    cur.error((text ? "'" + std::string(head) + "'" : std::string("binary data")) +
              " follows the binary POINTS: expected a section such as CELLS or POINT_DATA (does the POINTS count match the points in the file?)");
}

/// The sections after POINTS: cells are skipped, POINT_DATA / CELL_DATA arrays are read when
/// asked for (point arrays only) and skipped otherwise.
class VtkDataWalker {
public:
    VtkDataWalker(VtkCursor& cur, bool binary, std::uint64_t points, AttributeSink& sink)
        : cur_(cur), binary_(binary), points_(points), sink_(sink) {}

    void run() {
        for (auto l = cur_.line(); l; l = cur_.line()) {
            const auto t = split_ws(*l);
            const std::string kw = upper(t[0]);
            if (kw == "CELLS" || kw == "VERTICES" || kw == "LINES" || kw == "POLYGONS" || kw == "TRIANGLE_STRIPS") cells(t, kw);
            else if (kw == "OFFSETS") cur_.skip_array(offsets_, type_of(t, 1, "OFFSETS <type>"), binary_);
            else if (kw == "CONNECTIVITY") cur_.skip_array(connectivity_, type_of(t, 1, "CONNECTIVITY <type>"), binary_);
            else if (kw == "CELL_TYPES") cur_.skip_array(count(t, 1, "CELL_TYPES <n>"), Scalar::I32, binary_);
            else if (kw == "POINT_DATA") point_data(t);
            else if (kw == "CELL_DATA") { tuples_ = count(t, 1, "CELL_DATA <n>"); point_mode_ = false; }
            else if (kw == "SCALARS") scalars(t);
            else if (kw == "VECTORS" || kw == "NORMALS") array(t, 2, 3, "<name> <type>");
            else if (kw == "TENSORS") array(t, 2, 9, "<name> <type>");
            else if (kw == "TEXTURE_COORDINATES") array(t, 3, count(t, 2, "TEXTURE_COORDINATES <name> <dim> <type>"), "<name> <dim> <type>");
            else if (kw == "COLOR_SCALARS") skip_bytes_or_floats(mul(tuples_, count(t, 2, "COLOR_SCALARS <name> <n>")));
            else if (kw == "LOOKUP_TABLE") skip_bytes_or_floats(mul(4, count(t, 2, "LOOKUP_TABLE <name> <size>")));
            else if (kw == "FIELD") field(t);
            else if (kw == "METADATA") skip_metadata(cur_);
            else cur_.error("unexpected '" + std::string(t[0].substr(0, 40)) + "' after POINTS: expected a cell section, POINT_DATA or CELL_DATA");
        }
    }

private:
    std::uint64_t count(const std::vector<std::string_view>& t, std::size_t i, const char* form) {
        if (t.size() <= i) cur_.error(std::string("expected ") + form);
        return parse_count(cur_, t[i], form);
    }
    Scalar type_of(const std::vector<std::string_view>& t, std::size_t i, const char* form) {
        if (t.size() <= i) cur_.error(std::string("expected ") + form);
        const auto type = vtk_type(t[i]);
        if (!type) cur_.error("unsupported data type '" + std::string(t[i].substr(0, 40)) + "'");
        return *type;
    }
    std::uint64_t mul(std::uint64_t a, std::uint64_t b) {
        if (a != 0 && b > UINT64_MAX / a) cur_.error("array size " + std::to_string(a) + " x " + std::to_string(b) + " overflows");
        return a * b;
    }

    /// 4.x: <kw> <n> <size> and `size` ints; 5.x: <kw> <offsets> <connectivity>, then OFFSETS and
    /// CONNECTIVITY arrays of their own types (told apart by the line that follows).
    void cells(const std::vector<std::string_view>& t, const std::string& kw) {
        const std::string form = kw + " <n> <size>";
        const std::uint64_t a = count(t, 1, form.c_str()), b = count(t, 2, form.c_str());
        const auto m = cur_.mark();
        const auto next = cur_.line();
        const bool v5 = next && upper(next->substr(0, 7)) == "OFFSETS";
        cur_.reset(m);
        if (v5) {
            offsets_ = a;
            connectivity_ = b;
        } else {
            cur_.skip_array(b, Scalar::I32, binary_);
        }
    }

    void point_data(const std::vector<std::string_view>& t) {
        const std::uint64_t n = count(t, 1, "POINT_DATA <n>");
        if (n != points_) cur_.error("POINT_DATA " + std::to_string(n) + " does not match POINTS " + std::to_string(points_));
        tuples_ = n;
        point_mode_ = true;
    }

    /// SCALARS <name> <type> [<components>], an optional LOOKUP_TABLE line, the values.
    void scalars(const std::vector<std::string_view>& t) {
        const Scalar type = type_of(t, 2, "SCALARS <name> <type> [<components>]");
        const std::uint64_t comps = t.size() > 3 ? count(t, 3, "SCALARS <name> <type> <components>") : 1;
        const auto m = cur_.mark();
        const auto lut = cur_.line();
        if (!lut || upper(lut->substr(0, 12)) != "LOOKUP_TABLE") cur_.reset(m);
        values(t[1], comps, type);
    }

    /// <KW> <name> <type> (or <name> <dim> <type>) with `comps` values per tuple.
    void array(const std::vector<std::string_view>& t, std::size_t type_at, std::uint64_t comps, const char* form) {
        if (t.size() <= type_at) cur_.error(std::string("expected ") + std::string(t[0]) + " " + form);
        values(t[1], comps, type_of(t, type_at, form));
    }

    /// FIELD <name> <n>, then per array <name> <components> <tuples> <type> and the values; an
    /// array of POINT_DATA with one tuple per point is a point attribute.
    void field(const std::vector<std::string_view>& head) {
        const std::uint64_t arrays = count(head, 2, "FIELD <name> <number of arrays>");
        for (std::uint64_t a = 0; a < arrays; ++a) {
            const auto l = cur_.line();
            const auto t = l ? split_ws(*l) : std::vector<std::string_view>{};
            if (t.size() < 4) cur_.error("expected <array name> <components> <tuples> <type> in FIELD");
            const std::uint64_t comps = count(t, 1, "a component count"), tuples = count(t, 2, "a tuple count");
            const Scalar type = type_of(t, 3, "<array name> <components> <tuples> <type>");
            if (point_mode_ && tuples == points_) {
                values(t[0], comps, type);
                continue;
            }
            if (point_mode_ && sink_.requested(t[0]))
                cur_.error("FIELD array '" + std::string(t[0]) + "' has " + std::to_string(tuples) + " tuples, expected one per point (" +
                           std::to_string(points_) + ")");
            cur_.skip_array(mul(comps, tuples), type, binary_);
        }
    }

    /// One array of `tuples_` x comps values: read when it is a requested point attribute.
    void values(std::string_view name, std::uint64_t comps, Scalar type) {
        const std::uint64_t n = mul(tuples_, comps);
        const int index = point_mode_ ? sink_.wanted(name) : -1;
        if (index < 0) {
            cur_.skip_array(n, type, binary_);
            return;
        }
        const std::string where = "attribute '" + std::string(name) + "'";
        if (comps != 1 && comps != 3) cur_.error(where + " has " + std::to_string(comps) + " components, expected 1 or 3");
        sink_.append(index, static_cast<int>(comps), cur_.read_values(n, type, binary_), "");
    }

    /// COLOR_SCALARS and LOOKUP_TABLE values: unsigned char when binary, float when ASCII.
    void skip_bytes_or_floats(std::uint64_t n) { cur_.skip_array(n, binary_ ? Scalar::U8 : Scalar::F32, binary_); }

    VtkCursor& cur_;
    bool binary_;
    std::uint64_t points_;
    AttributeSink& sink_;
    std::uint64_t tuples_ = 0;  ///< tuples per array in the current POINT_DATA / CELL_DATA
    bool point_mode_ = false;
    std::uint64_t offsets_ = 0, connectivity_ = 0;  ///< 5.x sizes of the next OFFSETS / CONNECTIVITY
};

/// POLYGONS or CELLS <n> <size>: n polygons as <k> i0 .. ik-1, fan-triangulated (CELL_TYPES
/// says whether CELLS are polygons: check_cell_types).
void read_polygons(VtkCursor& cur, const std::vector<std::string_view>& t, bool binary, Mesh& mesh) {
    const std::string kw = upper(t[0]);
    if (t.size() < 3) cur.error("expected " + kw + " <n> <size>");
    const std::uint64_t n = parse_count(cur, t[1], (kw + " <n> <size>").c_str());
    const std::uint64_t size = parse_count(cur, t[2], (kw + " <n> <size>").c_str());
    const auto v = cur.read_ints(size, Scalar::I32, binary);
    std::uint64_t p = 0;
    for (std::uint64_t i = 0; i < n; ++i) {
        if (p >= v.size() || v[p] < 0 || static_cast<std::uint64_t>(v[p]) > v.size() - p - 1)
            cur.error(kw + ": polygon " + std::to_string(i) + " runs past the declared size");
        const std::uint64_t k = static_cast<std::uint64_t>(v[p]);
        for (std::uint64_t j = 1; j + 1 < k; ++j)
            for (std::uint64_t c : {std::uint64_t(0), j, j + 1}) {
                const std::int64_t idx = v[p + 1 + c];
                if (idx < 0 || static_cast<std::uint64_t>(idx) >= mesh.vertex_count())
                    cur.error(kw + ": vertex index " + std::to_string(idx) + " out of range");
                mesh.triangles.push_back(static_cast<std::uint32_t>(idx));
            }
        p += k + 1;
    }
}

/// CELL_TYPES <n>: every cell a triangle (5), polygon (7) or quad (9), which CELLS fan-triangulates.
void check_cell_types(VtkCursor& cur, const std::vector<std::string_view>& t, bool binary) {
    if (t.size() < 2) cur.error("expected CELL_TYPES <n>");
    const auto types = cur.read_ints(parse_count(cur, t[1], "CELL_TYPES <n>"), Scalar::I32, binary);
    for (std::size_t i = 0; i < types.size(); ++i)
        if (types[i] != 5 && types[i] != 7 && types[i] != 9)
            cur.error("CELL_TYPES: cell " + std::to_string(i) + " has type " + std::to_string(types[i]) +
                      ", not a triangle, polygon or quad");
}

/// One POINT_DATA array of a mesh: SCALARS level (the vertex level), NORMALS, other SCALARS
/// (1 or 3 components) and VECTORS as vertex attributes.
void read_point_array(VtkCursor& cur, const std::vector<std::string_view>& t, bool binary, Mesh& mesh) {
    const std::string kw = upper(t[0]);
    const bool scalars = kw == "SCALARS";
    if (t.size() < 3) cur.error("expected " + kw + " <name> <type>");
    const auto type = vtk_type(t[2]);
    if (!type) cur.error("unsupported " + kw + " type '" + std::string(t[2]) + "'");
    std::uint64_t comps = scalars ? 1 : 3;
    if (scalars && t.size() > 3) comps = parse_count(cur, t[3], "a component count");
    if (comps != 1 && comps != 3) cur.error(kw + " " + std::string(t[1]) + ": " + std::to_string(comps) + " components, expected 1 or 3");
    if (scalars) {
        auto lut = cur.line();
        if (!lut || upper(lut->substr(0, 12)) != "LOOKUP_TABLE") cur.error("expected LOOKUP_TABLE default");
    }
    const std::uint64_t n = comps * mesh.vertex_count();
    if (scalars && t[1] == "level" && comps == 1) {
        const auto v = cur.read_ints(n, *type, binary);
        for (const std::int64_t level : v)
            if (level < 0 || level > 255) cur.error("vertex level " + std::to_string(level) + " out of range 0..255");
        mesh.vertex_level.assign(v.begin(), v.end());
    } else if (kw == "NORMALS" || (kw == "VECTORS" && t[1] == "Normals")) {  // VECTORS Normals: write_mesh's
        mesh.normals = cur.read_values(n, *type, binary);
    } else {
        mesh.attributes.push_back({std::string(t[1]), int(comps), cur.read_values(n, *type, binary)});
    }
}

}  // namespace

ParticleSet read_vtk(const ReadRequest& r) {
    VtkCursor cur(r.path, r.data);
    const bool binary = read_header(cur);
    ParticleSet set;
    set.positions = read_points_section(cur, binary, r.keep_invalid);
    if (binary) require_section_after_binary_points(cur);
    AttributeSink sink(r);
    if (!r.attributes.empty()) VtkDataWalker(cur, binary, set.size(), sink).run();  // positions only: stop at POINTS
    set.attributes = sink.finish(set.size());
    return set;
}

Mesh read_vtk_mesh(const std::string& path, const std::string& data) {
    VtkCursor cur(path, data);
    const bool binary = read_header(cur);
    Mesh mesh;
    mesh.positions = read_points_section(cur, binary, false);
    bool point_data = false;
    for (auto l = cur.line(); l; l = cur.line()) {
        const auto t = split_ws(*l);
        const std::string kw = upper(t[0]);
        if (kw == "POLYGONS" || kw == "CELLS") {
            read_polygons(cur, t, binary, mesh);
        } else if (kw == "CELL_TYPES") {
            check_cell_types(cur, t, binary);
        } else if (kw == "POINT_DATA") {
            if (t.size() < 2 || parse_count(cur, t[1], "POINT_DATA <n>") != mesh.vertex_count())
                cur.error("POINT_DATA count does not match the " + std::to_string(mesh.vertex_count()) + " points");
            point_data = true;
        } else if (point_data && (kw == "SCALARS" || kw == "NORMALS" || kw == "VECTORS")) {
            read_point_array(cur, t, binary, mesh);
        } else if (kw == "FIELD") {
            skip_field(cur, t, binary);
        } else {
            cur.error("unexpected '" + std::string(t[0]) + "' in a mesh file (expected POLYGONS, CELLS or POINT_DATA arrays)");
        }
    }
    return mesh;
}

}  // namespace trilevel::io
