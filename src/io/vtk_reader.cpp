// Legacy VTK (.vtk): ASCII or BINARY (big-endian), versions 2.0-5.1, any dataset type; only the
// POINTS section is read. FIELD and METADATA blocks before POINTS are skipped.
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

    /// Error at the line of the last line or token read.
    [[noreturn]] void error(const std::string& what) const { fail(path_, "line " + std::to_string(err_line_) + ": " + what); }
    [[noreturn]] void error_at(const std::string& what) const { fail(path_, "offset " + std::to_string(pos_) + ": " + what); }

    /// Reads `count` values of type t (binary big-endian or ASCII) as floats.
    std::vector<float> read_array(std::uint64_t count, Scalar t, bool binary) {
        return binary ? read_binary(count, t) : read_ascii(count);
    }

    /// Skips `count` values (binary or ASCII) without converting them.
    void skip_array(std::uint64_t count, Scalar t, bool binary) {
        if (binary) {
            check_binary_size(count, t);
            pos_ += count * scalar_size(t);
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
            pos_ += count * scalar_size(t);
            return out;
        }
        const std::uint64_t left = data_.size() - std::min<std::size_t>(pos_, data_.size());
        if (count > left / 2 + 1) error("truncated ASCII data: " + std::to_string(count) + " values cannot fit");
        std::vector<std::int64_t> out(count);
        for (std::uint64_t i = 0; i < count; ++i) {
            const std::string_view tok = next_token();
            double v;
            if (tok.empty()) error("truncated ASCII data: found " + std::to_string(i) + " of " + std::to_string(count) + " values");
            if (!parse_double(tok, v)) error("malformed integer '" + std::string(tok.substr(0, 40)) + "'");
            if (!is_int64(v)) error("integer '" + std::string(tok.substr(0, 40)) + "' is not whole or out of range");
            out[i] = static_cast<std::int64_t>(v);
        }
        return out;
    }

private:
    /// A whole number that an int64 holds (checked before the cast, which would overflow).
    static bool is_int64(double v) { return v == std::floor(v) && v >= -0x1p63 && v < 0x1p63; }

    void check_binary_size(std::uint64_t count, Scalar t) const {
        const std::uint64_t left = data_.size() - std::min<std::size_t>(pos_, data_.size());
        if (count > left / scalar_size(t))
            error_at("truncated binary data: expected " + std::to_string(count) + " values of " +
                     std::to_string(scalar_size(t)) + " bytes, only " + std::to_string(left) + " bytes left");
    }

    std::vector<float> read_binary(std::uint64_t count, Scalar t) {
        check_binary_size(count, t);
        auto out = convert_coords(path_, data_.data() + pos_, count, t, true);
        pos_ += count * scalar_size(t);
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

    std::vector<float> read_ascii(std::uint64_t count) {
        // every value takes at least two bytes (a digit and a separator): bound before allocating
        const std::uint64_t left = data_.size() - std::min<std::size_t>(pos_, data_.size());
        if (count > left / 2 + 1)
            error("truncated ASCII data: " + std::to_string(count) + " values cannot fit in the " +
                  std::to_string(left) + " bytes left");
        std::vector<float> out(count);
        for (std::uint64_t i = 0; i < count; ++i) {
            const std::string_view tok = next_token();
            if (tok.empty()) error("truncated ASCII data: found " + std::to_string(i) + " of " + std::to_string(count) + " values");
            double v;
            if (!parse_double(tok, v)) error("malformed number '" + std::string(tok.substr(0, 40)) + "'");
            if (!std::isfinite(v) || std::fabs(v) > 3.4028234663852886e38)
                error("particle " + std::to_string(i / 3) + ": non-finite coordinate '" + std::string(tok.substr(0, 40)) + "'");
            out[i] = static_cast<float>(v);
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
std::vector<float> read_points_section(VtkCursor& cur, bool binary) {
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
        return cur.read_array(3 * n, *type, binary);
    }
}

/// POLYGONS <n> <size>: n polygons as <k> i0 .. ik-1, fan-triangulated.
void read_polygons(VtkCursor& cur, const std::vector<std::string_view>& t, bool binary, Mesh& mesh) {
    if (t.size() < 3) cur.error("expected POLYGONS <n> <size>");
    const std::uint64_t n = parse_count(cur, t[1], "POLYGONS <n> <size>");
    const std::uint64_t size = parse_count(cur, t[2], "POLYGONS <n> <size>");
    const auto v = cur.read_ints(size, Scalar::I32, binary);
    std::uint64_t p = 0;
    for (std::uint64_t i = 0; i < n; ++i) {
        if (p >= v.size() || v[p] < 0 || static_cast<std::uint64_t>(v[p]) > v.size() - p - 1)
            cur.error("POLYGONS: polygon " + std::to_string(i) + " runs past the declared size");
        const std::uint64_t k = static_cast<std::uint64_t>(v[p]);
        for (std::uint64_t j = 1; j + 1 < k; ++j)
            for (std::uint64_t c : {std::uint64_t(0), j, j + 1}) {
                const std::int64_t idx = v[p + 1 + c];
                if (idx < 0 || static_cast<std::uint64_t>(idx) >= mesh.vertex_count())
                    cur.error("POLYGONS: vertex index " + std::to_string(idx) + " out of range");
                mesh.triangles.push_back(static_cast<std::uint32_t>(idx));
            }
        p += k + 1;
    }
}

/// POINT_DATA <n>, then SCALARS level <type> 1, LOOKUP_TABLE default, values.
void read_point_levels(VtkCursor& cur, bool binary, Mesh& mesh) {
    auto l = cur.line();
    const auto t = l ? split_ws(*l) : std::vector<std::string_view>{};
    if (t.size() < 3 || upper(t[0]) != "SCALARS" || t[1] != "level") return;  // other point data: ignored
    const auto type = vtk_type(t[2]);
    if (!type) cur.error("unsupported SCALARS type '" + std::string(t[2]) + "'");
    auto lut = cur.line();
    if (!lut || upper(lut->substr(0, 12)) != "LOOKUP_TABLE") cur.error("expected LOOKUP_TABLE default");
    const auto v = cur.read_ints(mesh.vertex_count(), *type, binary);
    mesh.vertex_level.assign(v.begin(), v.end());
}

}  // namespace

std::vector<float> read_vtk_points(const std::string& path, const std::string& data) {
    VtkCursor cur(path, data);
    const bool binary = read_header(cur);
    return read_points_section(cur, binary);
}

Mesh read_vtk_mesh(const std::string& path, const std::string& data) {
    VtkCursor cur(path, data);
    const bool binary = read_header(cur);
    Mesh mesh;
    mesh.positions = read_points_section(cur, binary);
    for (auto l = cur.line(); l; l = cur.line()) {
        const auto t = split_ws(*l);
        const std::string kw = upper(t[0]);
        if (kw == "POLYGONS") read_polygons(cur, t, binary, mesh);
        else if (kw == "POINT_DATA") read_point_levels(cur, binary, mesh);
        else cur.error("unexpected '" + std::string(t[0]) + "' in a mesh file (expected POLYGONS or POINT_DATA)");
    }
    return mesh;
}

}  // namespace trilevel::io
