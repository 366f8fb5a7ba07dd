// On-disk cache of compiled OpenCL program binaries, so that a CLI start
// does not compile the kernels again.
//
// Why our own cache when drivers keep theirs: PoCL's kernel cache is found by hashing the
// *preprocessed* source, so every start still runs clang's preprocessor over all kernels (a large
// share of a small run: bench/RESULTS-implementation.md). A program created from its binary skips that.
// A cache is never a reason to fail: a missing, unreadable, corrupt or stale entry only means the
// program is built from source again, and a failed write is ignored.
//
// Every new driver, trilevel version or key width adds an entry, so the
// directory is kept to a size limit, least recently used entries out first: a load renews an
// entry's modification time, and each store prunes.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace trilevel {

/// Where program binaries are kept: $TRILEVEL_CACHE_DIR if set (empty: caching off), else
/// $XDG_CACHE_HOME/trilevel, else $HOME/.cache/trilevel; empty when none of these is set.
std::string program_cache_dir();

/// File name of the entry for a program: a 64-bit FNV-1a hash, in hex, of everything that decides
/// the binary (kernel source, build options, device, driver and platform versions).
std::string program_cache_name(const std::vector<std::string_view>& identity);

/// The file of the entry for `name` in the cache directory `dir`.
std::string program_cache_path(const std::string& dir, const std::string& name);

/// The binary stored in `path` for `name`, if the file holds a complete, intact entry for it
/// (header with name and payload checksum); nullopt otherwise. A hit renews the file's modification
/// time (what prune_program_cache orders by).
std::optional<std::vector<unsigned char>> load_program_binary(const std::string& path, const std::string& name);

/// Stores `binary` for `name` at `path` (creating the directory), through a temporary file renamed
/// into place, so concurrent processes never read half an entry. Returns false on any failure.
bool store_program_binary(const std::string& path, const std::string& name, const std::vector<unsigned char>& binary);

/// The cache's size limit in bytes: $TRILEVEL_CACHE_MAX_MB (whole MiB, 0 = keep only the entry in
/// use) if set to a number, else kProgramCacheMaxBytes.
inline constexpr std::uint64_t kProgramCacheMaxBytes = 64ull << 20;
std::uint64_t program_cache_max_bytes();

/// Removes from `dir` the entries (program_cache_path files) beyond `max_bytes`, newest
/// modification time first (ties by name), always keeping the entry for name `keep`; and temporary
/// files (`*.clbin.tmp.*`) older than an hour, left by writers that died. Other files are never
/// touched. Returns how many files it removed; errors only mean fewer are removed.
std::size_t prune_program_cache(const std::string& dir, std::uint64_t max_bytes, const std::string& keep);

}  // namespace trilevel
