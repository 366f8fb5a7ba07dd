#include "io/io_common.hpp"

#include <atomic>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <filesystem>

#include <csignal>
#include <cstdlib>
#include <cstring>

#include <fcntl.h>
#include <unistd.h>
#ifdef __linux__
#include <sys/mman.h>
#endif

#include "environment.hpp"

namespace fs = std::filesystem;

namespace trilevel::io {

void fail(const std::string& path, const std::string& what) {
    // quoted file content may hold anything: keep the message one printable line of sane length
    std::string msg = what.size() > 400 ? what.substr(0, 400) + "..." : what;
    for (char& c : msg) {  // control bytes and (quoted binary) non-ASCII bytes would garble a terminal
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
        if (static_cast<unsigned char>(c) >= 0x80) c = '?';
    }
    throw Error(path + ": " + msg);
}

void require_file(const std::string& path) {
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (!fs::exists(st)) fail(path, "no such file");
    if (fs::is_directory(st)) fail(path, "is a directory, expected a file");
    // a device such as /dev/zero never ends: only files and pipes are read
    if (fs::is_character_file(st) || fs::is_block_file(st) || fs::is_socket(st))
        fail(path, "is a device or socket, expected a file");
}

std::string read_file(const std::string& path) {
    require_file(path);
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) fail(path, std::string("cannot open: ") + std::strerror(errno));
    std::string data;
    char chunk[1 << 16];
    std::size_t got;
    // Read by chunks rather than trusting file_size: works for pipes and files that change.
    const auto size = fs::is_regular_file(st) ? fs::file_size(path, ec) : 0;
    if (!ec && size > 0) data.reserve(size);
    while ((got = std::fread(chunk, 1, sizeof chunk, f)) > 0) data.append(chunk, got);
    const bool bad = std::ferror(f);
    std::fclose(f);
    if (bad) fail(path, "read error");
    if (data.empty()) fail(path, "empty file");
    return data;
}

void release_unused_capacity([[maybe_unused]] std::vector<float>& v) {
#ifdef __linux__
    const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
    const auto first = (reinterpret_cast<std::uintptr_t>(v.data() + v.size()) + page - 1) & ~(page - 1);
    const auto end = reinterpret_cast<std::uintptr_t>(v.data() + v.capacity()) & ~(page - 1);
    // Memory of a private mapping or the heap: MADV_DONTNEED drops the pages (zero-filled if
    // touched again). Only worth a system call from a few pages on; a failure just keeps them.
    if (end >= first + 16 * page) madvise(reinterpret_cast<void*>(first), end - first, MADV_DONTNEED);
#endif
}

std::string extension_of(const std::string& path) {
    std::string ext = fs::path(path).extension().string();
    if (!ext.empty() && ext[0] == '.') ext.erase(0, 1);
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

std::string ArrayLocation::at(std::size_t value_index, std::size_t value_size) const {
    if (base != SIZE_MAX) return "offset " + std::to_string(base + value_index * value_size) + ": ";
    return label.empty() ? std::string() : label + ": ";
}

void check_finite(const std::string& path, const std::vector<float>& xyz, const ArrayLocation& where) {
    for (std::size_t i = 0; i < xyz.size(); ++i)
        if (!std::isfinite(xyz[i]))
            fail(path, where.at(i, 4) + "particle " + std::to_string(i / 3) + ": non-finite coordinate (NaN or Inf)");
}

std::string coordinate_problem(double v, std::string_view text) {
    std::string quoted(1, '\'');  // appended, not "'" + string: g++ 12 warns falsely on that (-Wrestrict)
    quoted.append(text.substr(0, 40)).push_back('\'');
    if (!std::isfinite(v)) return "non-finite coordinate " + (text.empty() ? std::string("(NaN or Inf)") : quoted);
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return "coordinate " + (text.empty() ? std::string(buf) : quoted) + " is beyond the float range (+-3.4e38)";
}

float to_float_checked(const std::string& path, double v, std::size_t value_index, const std::string& where) {
    if (!finite_float(v)) fail(path, where + "particle " + std::to_string(value_index / 3) + ": " + coordinate_problem(v));
    return static_cast<float>(v);
}

void missing_attribute(const std::string& path, const std::string& name, const std::vector<std::string>& available) {
    std::string list;
    for (const auto& a : available) list += (list.empty() ? "" : ", ") + a;
    fail(path, "no point attribute '" + name + "'" + (list.empty() ? " (the file has none)" : " (the file has: " + list + ")"));
}

std::string byte_size_text(std::uint64_t bytes) {
    static const char* units[] = {"bytes", "kB", "MB", "GB", "TB", "PB", "EB"};
    double v = static_cast<double>(bytes);
    int u = 0;
    while (v >= 1000.0 && u < 6) { v /= 1000.0; ++u; }
    char buf[32];
    std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.3g %s", v, units[u]);
    return buf;
}

std::uint64_t mul_checked(const std::string& path, const std::string& where, std::uint64_t a, std::uint64_t b,
                          const char* what) {
    if (a != 0 && b > UINT64_MAX / a) fail(path, where + ": " + what + " overflows");
    return a * b;
}

std::size_t scalar_size(Scalar t) {
    switch (t) {
        case Scalar::I8: case Scalar::U8: return 1;
        case Scalar::I16: case Scalar::U16: return 2;
        case Scalar::I32: case Scalar::U32: case Scalar::F32: return 4;
        default: return 8;
    }
}

double load_scalar(const char* p, Scalar t, bool big) {
    switch (t) {
        case Scalar::I8: return load<std::int8_t>(p, big);
        case Scalar::U8: return load<std::uint8_t>(p, big);
        case Scalar::I16: return load<std::int16_t>(p, big);
        case Scalar::U16: return load<std::uint16_t>(p, big);
        case Scalar::I32: return load<std::int32_t>(p, big);
        case Scalar::U32: return load<std::uint32_t>(p, big);
        case Scalar::I64: return static_cast<double>(load<std::int64_t>(p, big));
        case Scalar::U64: return static_cast<double>(load<std::uint64_t>(p, big));
        case Scalar::F32: return load<float>(p, big);
        case Scalar::F64: return load<double>(p, big);
    }
    return 0.0;
}

std::vector<float> convert_values(const char* p, std::size_t count, Scalar t, bool big) {
    std::vector<float> out(count);
    const std::size_t size = scalar_size(t);
    if (t == Scalar::F32) {
        for (std::size_t i = 0; i < count; ++i) out[i] = load<float>(p + i * 4, big);
    } else {
        for (std::size_t i = 0; i < count; ++i) out[i] = narrow_to_float(load_scalar(p + i * size, t, big));
    }
    return out;
}

std::vector<float> convert_coords(const std::string& path, const char* p, std::size_t count, Scalar t,
                                  bool big, bool finite_only, const ArrayLocation& where) {
    if (!finite_only) return convert_values(p, count, t, big);  // the caller drops NaN/Inf particles
    std::vector<float> out(count);
    const std::size_t size = scalar_size(t);
    if (t == Scalar::F32) {  // the common case: no double round trip
        for (std::size_t i = 0; i < count; ++i) out[i] = load<float>(p + i * 4, big);
        check_finite(path, out, where);
        return out;
    }
    for (std::size_t i = 0; i < count; ++i) {
        const double v = load_scalar(p + i * size, t, big);
        // where.at() only for a value that fails (to_float_checked then throws)
        out[i] = finite_float(v) ? static_cast<float>(v) : to_float_checked(path, v, i, where.at(i, size));
    }
    return out;
}

bool parse_double(std::string_view t, double& out) {
    if (!t.empty() && t[0] == '+') t.remove_prefix(1);
    const auto r = std::from_chars(t.data(), t.data() + t.size(), out);
    return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

bool parse_u64(std::string_view t, std::uint64_t& out) {
    if (!t.empty() && t[0] == '+') t.remove_prefix(1);
    const auto r = std::from_chars(t.data(), t.data() + t.size(), out);
    return r.ec == std::errc() && r.ptr == t.data() + t.size();
}

std::vector<std::string_view> split_ws(std::string_view s) {
    std::vector<std::string_view> out;
    std::size_t i = 0;
    auto ws = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; };
    while (i < s.size()) {
        while (i < s.size() && ws(s[i])) ++i;
        std::size_t j = i;
        while (j < s.size() && !ws(s[j])) ++j;
        if (j > i) out.push_back(s.substr(i, j - i));
        i = j;
    }
    return out;
}

std::string upper(std::string_view s) {
    std::string u(s);
    for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return u;
}

namespace {

// Named temporaries of live writers, for the signal handler: it may only read atomics and call
// unlink (async-signal-safe). Each slot points at the writer's own temp_ string.
constexpr int kTempSlots = 64;
std::atomic<const char*> g_temp_names[kTempSlots];

void remove_temporaries_and_die(int sig) {
    for (auto& slot : g_temp_names)
        if (const char* name = slot.load()) ::unlink(name);
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

}  // namespace

void remove_temporaries_on_signals() {
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, remove_temporaries_and_die);
}

void AtomicWriter::publish_temp_name(bool on) {
    if (on) {
        for (int i = 0; i < kTempSlots && slot_ < 0; ++i) {
            const char* expected = nullptr;
            if (g_temp_names[i].compare_exchange_strong(expected, temp_.c_str())) slot_ = i;
        }
    } else if (slot_ >= 0) {
        g_temp_names[slot_].store(nullptr);
        slot_ = -1;
    }
}

AtomicWriter::AtomicWriter(const std::string& path) : path_(path) {
    fs::path target(path);
    if (target.filename().empty()) fail(path, "output path names no file");
    std::error_code ec;
    // Through a symbolic link to the file it names (renaming over the link would replace the link).
    for (int hops = 0; fs::is_symlink(target, ec) && hops < 40; ++hops) {
        const fs::path next = fs::read_symlink(target, ec);
        if (ec) break;
        target = next.is_absolute() ? next : target.parent_path() / next;
    }
    target_ = target.string();
    fs::path dir = target.parent_path();
    if (!dir.empty() && !fs::is_directory(dir, ec))
        fail(path, "output directory '" + dir.string() + "' does not exist");
    if (fs::is_directory(target, ec)) fail(path, "output path is a directory");
    std::string name(1, '.');  // hidden, beside the target so that rename stays on one file system
    name += target.filename().string();
    name += ".tmp.";
    name += std::to_string(::getpid());
    static std::atomic<unsigned> counter{0};  // distinct temporaries for writers in several threads
    name += '.';
    name += std::to_string(counter++);
    temp_ = (dir / name).string();
#ifdef O_TMPFILE
    // Unnamed until commit; linking it needs /proc/self/fd (linkat with AT_EMPTY_PATH needs a privilege).
    // TRILEVEL_NO_TMPFILE=1 (tests) takes the named-temporary path file systems without O_TMPFILE take.
    if (!environment().no_tmpfile && ::access("/proc/self/fd", X_OK) == 0) {
        const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
        if (fd >= 0) {
            file_ = ::fdopen(fd, "wb");
            if (!file_) ::close(fd);
            unnamed_ = file_ != nullptr;
        }
    }
#endif
    if (!file_) {
        publish_temp_name(true);  // before the file exists: a signal right after fopen still removes it
        file_ = std::fopen(temp_.c_str(), "wb");
        if (!file_) {
            publish_temp_name(false);
            fail(path, std::string("cannot create output file: ") + std::strerror(errno));
        }
    }
    buffer_.reserve(std::size_t(4) << 20);
}

AtomicWriter::~AtomicWriter() {
    if (file_) std::fclose(file_);
    if (!committed_ && !unnamed_) {
        std::error_code ec;
        fs::remove(temp_, ec);
    }
    publish_temp_name(false);
}

void AtomicWriter::flush() {
    if (buffer_.empty()) return;
    if (std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
        fail(path_, std::string("write failed: ") + std::strerror(errno));
    buffer_.clear();
}

void AtomicWriter::write(const void* data, std::size_t n) {
    if (buffer_.size() + n > buffer_.capacity()) flush();
    if (n >= buffer_.capacity()) {
        if (std::fwrite(data, 1, n, file_) != n) fail(path_, std::string("write failed: ") + std::strerror(errno));
        return;
    }
    const char* p = static_cast<const char*>(data);
    buffer_.insert(buffer_.end(), p, p + n);
}

void AtomicWriter::commit() {
    flush();
    const bool bad = std::fflush(file_) != 0 || std::ferror(file_);
    if (bad) fail(path_, std::string("write failed: ") + std::strerror(errno));
    if (unnamed_) {  // give the finished file its temporary name, then rename it over the target
        const std::string self = "/proc/self/fd/" + std::to_string(::fileno(file_));
        publish_temp_name(true);  // before the name exists, as above
        if (::linkat(AT_FDCWD, self.c_str(), AT_FDCWD, temp_.c_str(), AT_SYMLINK_FOLLOW) != 0)
            fail(path_, std::string("cannot link the finished temporary file: ") + std::strerror(errno));
        unnamed_ = false;  // from here on temp_ names a file, removed if anything below fails
    }
    const bool close_bad = std::fclose(file_) != 0;
    file_ = nullptr;
    if (close_bad) fail(path_, std::string("write failed: ") + std::strerror(errno));
    std::error_code ec;
    fs::rename(temp_, target_, ec);
    if (ec) fail(path_, "cannot rename temporary file into place: " + ec.message());
    committed_ = true;
    publish_temp_name(false);
}

}  // namespace trilevel::io
