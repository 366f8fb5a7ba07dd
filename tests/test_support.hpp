// Helpers shared by the tests: where ../shared is, temporary files.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include <unistd.h>

#include <catch2/catch.hpp>

#include "stage_constants.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel::test {

/// ../shared/data beside the checkout, or empty when absent (tests then SKIP with a message).
inline std::filesystem::path shared_data_dir() {
    std::filesystem::path p = std::filesystem::path(TRILEVEL_SHARED_DIR) / "data";
    return std::filesystem::is_directory(p) ? p : std::filesystem::path{};
}

#define TRILEVEL_REQUIRE_SHARED_DATA(dir)                                                   \
    const auto dir = ::trilevel::test::shared_data_dir();                                   \
    if (dir.empty()) {                                                                      \
        WARN("SKIPPED: ../shared/data is absent beside the checkout; real-frame test skipped"); \
        return;                                                                             \
    }

/// The same floats bit for bit (NaN payloads and the sign of zero included).
/// The smallest Params::memory_limit_bytes a frame that reported `st` runs under: its device
/// buffers (Stats::device_memory_bytes) and the triangulation's host estimate both fit.
inline std::uint64_t frame_memory_need(const Stats& st) {
    return std::max(st.device_memory_bytes, std::uint64_t(double(st.fine_points) * constants::kMeshBytesPerFinePoint));
}

inline bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

/// Bit-identical meshes (the determinism tests): geometry, topology, levels, triangle kinds,
/// normals and vertex attributes.
inline bool same_mesh(const Mesh& a, const Mesh& b) {
    if (a.attributes.size() != b.attributes.size()) return false;
    for (std::size_t i = 0; i < a.attributes.size(); ++i)
        if (a.attributes[i].name != b.attributes[i].name || a.attributes[i].components != b.attributes[i].components ||
            !same_bits(a.attributes[i].values, b.attributes[i].values))
            return false;
    return same_bits(a.positions, b.positions) && a.triangles == b.triangles && a.vertex_level == b.vertex_level &&
           a.triangle_kind == b.triangle_kind && same_bits(a.normals, b.normals);
}

/// Sets an environment variable for one scope (each test process runs its cases one at a time).
struct ScopedEnv {
    std::string name;
    ScopedEnv(const char* n, const char* value) : name(n) { ::setenv(n, value, 1); }
    ~ScopedEnv() { ::unsetenv(name.c_str()); }
};

/// A fresh temporary directory, removed at scope exit.
struct TempDir {
    std::filesystem::path path;
    TempDir() {
        path = std::filesystem::temp_directory_path() /
               ("trilevel-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter()++));
        std::filesystem::create_directories(path);
    }
    ~TempDir() { std::error_code ec; std::filesystem::remove_all(path, ec); }
    std::string file(const std::string& name) const { return (path / name).string(); }
    static int& counter() { static int c = 0; return c; }
};

/// The n.x * n.y * n.z points origin + spacing * (i, j, k), x fastest, each coordinate then moved
/// by a uniform draw in [-jitter, jitter] from a generator seeded with `seed` (none when jitter is 0).
inline std::vector<glm::vec3> lattice_points(glm::ivec3 n, glm::vec3 origin, float spacing, float jitter = 0.0f,
                                             std::uint32_t seed = 0) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> move(-jitter, jitter);
    std::vector<glm::vec3> x;
    x.reserve(std::size_t(n.x) * std::size_t(n.y) * std::size_t(n.z));
    for (int k = 0; k < n.z; ++k)
        for (int j = 0; j < n.y; ++j)
            for (int i = 0; i < n.x; ++i) {
                glm::vec3 p = origin + spacing * glm::vec3(i, j, k);
                if (jitter > 0.0f) p += glm::vec3(move(rng), move(rng), move(rng));
                x.push_back(p);
            }
    return x;
}

/// n points in the box corner .. corner + spread (each coordinate a uniform draw from a generator
/// seeded with `seed`): a pile of particles when spread is far under their radius.
inline std::vector<glm::vec3> pile_points(int n, glm::vec3 corner, float spread, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> draw(0.0f, spread);
    std::vector<glm::vec3> x;
    for (int i = 0; i < n; ++i) x.push_back(corner + glm::vec3{draw(rng), draw(rng), draw(rng)});  // braces: drawn in order
    return x;
}

}  // namespace trilevel::test
