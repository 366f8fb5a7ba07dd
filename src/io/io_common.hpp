// Shared helpers of the particle and mesh readers/writers: errors naming the file, whole-file
// reads, endian-aware loads, number parsing and atomic (temp + rename) buffered writes.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "trilevel/trilevel.hpp"

namespace trilevel::io {

/// Throws Error "<path>: <what>".
[[noreturn]] void fail(const std::string& path, const std::string& what);

/// Error for a missing file or a directory.
void require_file(const std::string& path);

/// The whole file; Error for a missing file, a directory, an empty or unreadable file.
std::string read_file(const std::string& path);

/// Gives the whole pages of `v`'s capacity past its size back to the system, without moving `v`
/// (shrink_to_fit would copy it, and hold both copies meanwhile): for a buffer that was filled
/// and then cut short, such as inflated point records turned into positions in place. They read
/// as zeros if `v` grows over them again. Linux only (madvise); elsewhere it does nothing.
void release_unused_capacity(std::vector<float>& v);

/// Lower-case extension without the dot ("vtk"), empty when there is none.
std::string extension_of(const std::string& path);

/// Where a coordinate array lies, for messages: `base` is the file offset of its first value
/// when the values are stored there uncompressed (then the message names the exact offset),
/// otherwise `label` (e.g. "offset 291: the Points") prefixes the message.
struct ArrayLocation {
    std::size_t base = SIZE_MAX;
    std::string label;
    std::string at(std::size_t value_index, std::size_t value_size) const;  ///< "offset N: " or "label: " or ""
};

/// Whether a double read from a file is a finite value that fits a float (a coordinate).
inline bool finite_float(double v) { return std::isfinite(v) && std::fabs(v) <= 3.4028234663852886e38; }

/// Error naming the first non-finite coordinate.
void check_finite(const std::string& path, const std::vector<float>& xyz, const ArrayLocation& where = {});

/// "non-finite coordinate (NaN or Inf)", or "coordinate 1e+300 is beyond the float range (+-3.4e38)":
/// what is wrong with a coordinate that finite_float refuses. `text`, where given, is the number
/// as the file writes it, quoted in the message instead of the value.
std::string coordinate_problem(double v, std::string_view text = {});

/// Narrows a double coordinate; Error when it is not finite or does not fit a float.
float to_float_checked(const std::string& path, double v, std::size_t value_index, const std::string& where = {});

/// Error "no point attribute 'name' (the file has: a, b)".
[[noreturn]] void missing_attribute(const std::string& path, const std::string& name,
                                    const std::vector<std::string>& available);

inline std::uint16_t bswap(std::uint16_t v) { return __builtin_bswap16(v); }
inline std::uint32_t bswap(std::uint32_t v) { return __builtin_bswap32(v); }
inline std::uint64_t bswap(std::uint64_t v) { return __builtin_bswap64(v); }

/// Loads a scalar of type T stored with the given endianness at p (no alignment needed).
template <class T>
T load(const char* p, bool big_endian) {
    constexpr bool host_big = false;  // the project targets little-endian hosts (x86-64, arm64)
    T v;
    if constexpr (sizeof(T) == 1) {
        std::memcpy(&v, p, 1);
    } else {
        using U = std::conditional_t<sizeof(T) == 2, std::uint16_t,
                                     std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>;
        U u;
        std::memcpy(&u, p, sizeof(U));
        if (big_endian != host_big) u = bswap(u);
        std::memcpy(&v, &u, sizeof(T));
    }
    return v;
}

/// Stores v at p with the given endianness.
template <class T>
void store(char* p, T v, bool big_endian) {
    using U = std::conditional_t<sizeof(T) == 2, std::uint16_t,
                                 std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>;
    if constexpr (sizeof(T) == 1) {
        std::memcpy(p, &v, 1);
    } else {
        U u;
        std::memcpy(&u, &v, sizeof(U));
        if (big_endian) u = bswap(u);
        std::memcpy(p, &u, sizeof(U));
    }
}

/// Numeric types found in particle files.
enum class Scalar { I8, U8, I16, U16, I32, U32, I64, U64, F32, F64 };
std::size_t scalar_size(Scalar t);

/// Reads one scalar of type t at p as a double.
double load_scalar(const char* p, Scalar t, bool big_endian);

/// Converts `count` values of type t starting at p to float coordinates, rejecting non-finite ones
/// unless `finite_only` is false (then NaN stays NaN and out-of-range values become +-Inf).
std::vector<float> convert_coords(const std::string& path, const char* p, std::size_t count, Scalar t,
                                  bool big_endian, bool finite_only = true, const ArrayLocation& where = {});

/// A double as the nearest float, +-Inf beyond the float range (no undefined conversion), NaN kept.
inline float narrow_to_float(double v) {
    if (v > 3.4028234663852886e38) return __builtin_inff();
    if (v < -3.4028234663852886e38) return -__builtin_inff();
    return static_cast<float>(v);
}

/// Converts `count` values of type t starting at p to floats as they are (attribute values).
std::vector<float> convert_values(const char* p, std::size_t count, Scalar t, bool big_endian);

/// "3 kB", "12 EB": a byte count for messages about sizes claimed by a header.
std::string byte_size_text(std::uint64_t bytes);

/// a * b, or Error "<path>: <where>: <what> overflows" when the product does not fit 64 bits.
std::uint64_t mul_checked(const std::string& path, const std::string& where, std::uint64_t a, std::uint64_t b,
                          const char* what);

/// The largest size a zlib/deflate stream of `compressed` bytes can inflate to (deflate's best
/// ratio is 1032:1): a bound for sizes claimed by headers, checked before inflating.
inline std::uint64_t max_inflated_size(std::uint64_t compressed) {
    return compressed > UINT64_MAX / 1032 ? UINT64_MAX : compressed * 1032;
}

/// Parses a whole token as a number; false when it is not one.
bool parse_double(std::string_view token, double& out);
bool parse_u64(std::string_view token, std::uint64_t& out);

/// Splits on ASCII whitespace.
std::vector<std::string_view> split_ws(std::string_view line);

/// Upper-cases ASCII.
std::string upper(std::string_view s);

/// A file written through a temporary in the target directory and renamed on commit();
/// destroyed uncommitted, it removes the temporary. Writes are buffered in large blocks.
///
/// The temporary is an unnamed file (O_TMPFILE) where the file system allows it: a process killed
/// mid-write, even by SIGKILL, leaves nothing behind. On commit it is linked as `.NAME.tmp.PID.N`
/// and renamed over NAME at once. Elsewhere the temporary is that named file from the start; a
/// SIGKILL may then leave it behind (never under the target's name), and SIGINT/SIGTERM remove it
/// when the program called remove_temporaries_on_signals(). A NAME that is a symbolic link is
/// written through: the file it points to is replaced (in that file's directory) and the link kept.
class AtomicWriter {
public:
    explicit AtomicWriter(const std::string& path);
    ~AtomicWriter();
    AtomicWriter(const AtomicWriter&) = delete;
    AtomicWriter& operator=(const AtomicWriter&) = delete;

    void write(const void* data, std::size_t n);
    void write(std::string_view s) { write(s.data(), s.size()); }
    void commit();
    const std::string& path() const { return path_; }

private:
    void flush();
    void publish_temp_name(bool on);
    std::string path_, target_, temp_;  ///< as given (messages), the file replaced, the temporary
    std::FILE* file_ = nullptr;
    bool unnamed_ = false;  // O_TMPFILE: temp_ names nothing until commit() links it
    int slot_ = -1;         // in the signal-cleanup registry
    std::vector<char> buffer_;
    bool committed_ = false;
};

/// Installs SIGINT, SIGTERM and SIGHUP handlers that remove the named temporaries of live
/// AtomicWriters and then die of the signal as before (for programs, not the library).
void remove_temporaries_on_signals();

/// Writes `count` floats in the given byte order (chunked conversion for big-endian).
void write_floats(AtomicWriter& out, const float* v, std::size_t count, bool big_endian);

}  // namespace trilevel::io
