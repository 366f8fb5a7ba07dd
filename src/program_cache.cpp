#include "program_cache.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string_view>
#include <system_error>

#include "environment.hpp"

namespace trilevel {
namespace {

constexpr char kMagic[] = "trilevel program binary 1\n";  // bump the digit when the layout changes

std::uint64_t fnv1a(const void* data, std::size_t n, std::uint64_t h = 0xcbf29ce484222325ULL) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ULL;
    return h;
}

/// Entry layout: magic, name and '\n', payload size and payload checksum (8 bytes each, host
/// order: an entry never leaves the machine that wrote it), payload.
std::string header(const std::string& name, std::uint64_t size, std::uint64_t checksum) {
    std::string h = kMagic + name + "\n";
    h.append(reinterpret_cast<const char*>(&size), sizeof size);
    h.append(reinterpret_cast<const char*>(&checksum), sizeof checksum);
    return h;
}

namespace fs = std::filesystem;

constexpr std::string_view kEntrySuffix = ".clbin";  // entry files: <name><suffix>
constexpr std::string_view kTemporaryMark = ".tmp.";  // an entry's temporary: its file, the mark, <pid>.<n>

/// Whether `file` is an entry's file name: a program_cache_name (16 hex digits) and the suffix.
bool is_entry_file(const std::string& file) {
    return file.size() == 16 + kEntrySuffix.size() && file.ends_with(kEntrySuffix) &&
           std::all_of(file.begin(), file.begin() + 16, [](unsigned char c) { return std::isxdigit(c); });
}

}  // namespace

std::string program_cache_dir() {
    const EnvironmentOverrides env = environment();
    if (env.cache_dir) return *env.cache_dir;  // "" turns the cache off
    if (!env.xdg_cache_home.empty()) return env.xdg_cache_home + "/trilevel";
    if (!env.home.empty()) return env.home + "/.cache/trilevel";
    return {};
}

std::string program_cache_name(const std::vector<std::string_view>& identity) {
    std::uint64_t h = 0xcbf29ce484222325ULL;
    for (std::string_view part : identity) {
        const std::uint64_t n = part.size();  // lengths keep ("ab", "c") apart from ("a", "bc")
        h = fnv1a(&n, sizeof n, h);
        h = fnv1a(part.data(), part.size(), h);
    }
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
    return buf;
}

std::string program_cache_path(const std::string& dir, const std::string& name) {
    return dir + "/" + name + std::string(kEntrySuffix);
}

std::optional<std::vector<unsigned char>> load_program_binary(const std::string& path, const std::string& name) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) return std::nullopt;
    const std::uint64_t file_size = std::uint64_t(in.tellg());
    std::string head(header(name, 0, 0).size(), '\0');
    if (file_size <= head.size() || !in.seekg(0).read(head.data(), std::streamsize(head.size()))) return std::nullopt;
    std::uint64_t size = 0, checksum = 0;
    std::memcpy(&size, head.data() + head.size() - 16, 8);
    std::memcpy(&checksum, head.data() + head.size() - 8, 8);
    if (size != file_size - head.size() || head != header(name, size, checksum)) return std::nullopt;
    std::vector<unsigned char> payload(size);
    if (!in.read(reinterpret_cast<char*>(payload.data()), std::streamsize(size)) ||
        fnv1a(payload.data(), payload.size()) != checksum)
        return std::nullopt;
    std::error_code ec;
    fs::last_write_time(path, fs::file_time_type::clock::now(), ec);  // recently used (prune order)
    return payload;
}

bool store_program_binary(const std::string& path, const std::string& name, const std::vector<unsigned char>& binary) {
    static std::atomic<unsigned> counter{0};
    std::error_code ec;
    const std::filesystem::path target(path);
    if (target.has_parent_path()) std::filesystem::create_directories(target.parent_path(), ec);
    const std::string tmp = path + std::string(kTemporaryMark) + std::to_string(::getpid()) + "." + std::to_string(counter++);
    {
        std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
        const std::string h = header(name, binary.size(), fnv1a(binary.data(), binary.size()));
        out.write(h.data(), std::streamsize(h.size()));
        out.write(reinterpret_cast<const char*>(binary.data()), std::streamsize(binary.size()));
        if (!out.flush()) {
            std::filesystem::remove(tmp, ec);
            return false;
        }
    }
    std::filesystem::rename(tmp, target, ec);
    if (!ec) return true;
    std::filesystem::remove(tmp, ec);
    return false;
}

std::uint64_t program_cache_max_bytes() {
    return environment().cache_max_bytes.value_or(kProgramCacheMaxBytes);  // not a size: the default
}

std::size_t prune_program_cache(const std::string& dir, std::uint64_t max_bytes, const std::string& keep) {
    struct Entry {
        fs::file_time_type time;
        std::string file;
        std::uint64_t size;
    };
    const std::string keep_file = fs::path(program_cache_path(dir, keep)).filename().string();
    const std::string temporary_mark = std::string(kEntrySuffix) + std::string(kTemporaryMark);
    const auto hour_ago = fs::file_time_type::clock::now() - std::chrono::hours(1);
    std::vector<Entry> others;  // every entry but the one in use
    std::vector<fs::path> remove;
    std::uint64_t total = 0;    // bytes kept so far: the entry in use first
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        std::error_code e;
        if (!it->is_regular_file(e) || e) continue;
        const std::string file = it->path().filename().string();
        const auto time = it->last_write_time(e);
        const std::uint64_t size = it->file_size(e);
        if (e) continue;
        if (file == keep_file) total += size;
        else if (is_entry_file(file)) others.push_back({time, file, size});
        else if (file.find(temporary_mark) != std::string::npos && time < hour_ago) remove.push_back(it->path());
    }
    std::sort(others.begin(), others.end(), [](const Entry& a, const Entry& b) {  // newest first, ties by name
        return a.time != b.time ? a.time > b.time : a.file < b.file;
    });
    for (const Entry& e : others)
        if ((total += e.size) > max_bytes) remove.push_back(fs::path(dir) / e.file);
    std::size_t removed = 0;
    for (const fs::path& p : remove) removed += fs::remove(p, ec) && !ec;
    return removed;
}

}  // namespace trilevel
