// The on-disk cache of program binaries (src/program_cache.hpp): entries round-trip, damaged or
// foreign ones are refused, and a runtime built from a cached binary meshes like one built from
// source.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "io_test_files.hpp"
#include "opencl_runtime.hpp"
#include "program_cache.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"
#include "trilevel/trilevel.hpp"

using namespace trilevel;
using trilevel::test::same_mesh;
using trilevel::test::slurp;
using trilevel::test::write_bytes;
using trilevel::test::ScopedEnv;
using trilevel::test::TempDir;

namespace {

std::vector<std::filesystem::path> entries(const TempDir& dir) {
    std::vector<std::filesystem::path> out;
    for (const auto& e : std::filesystem::directory_iterator(dir.path)) out.push_back(e.path());
    return out;
}

std::vector<std::string> names(const TempDir& dir) {
    std::vector<std::string> out;
    for (const auto& e : entries(dir)) out.push_back(e.filename().string());
    std::sort(out.begin(), out.end());
    return out;
}

/// Writes `bytes` bytes to `dir/name`, last modified `age` ago.
void put_file(const TempDir& dir, const std::string& name, std::size_t bytes, std::chrono::minutes age) {
    write_bytes(dir.file(name), std::string(bytes, 'x'));
    std::filesystem::last_write_time(dir.file(name), std::filesystem::file_time_type::clock::now() - age);
}

std::string name_of(char c) { return std::string(16, c); }
std::string entry(char c) { return program_cache_path(".", name_of(c)).substr(2); }  // the entry's file name

}  // namespace

TEST_CASE("program cache pruning drops the least recently used entries and dead writers' files only",
          "[program_cache]") {
    using std::chrono::minutes;
    TempDir tmp;
    put_file(tmp, entry('1'), 1000, minutes(500));  // oldest
    put_file(tmp, entry('2'), 1000, minutes(400));
    put_file(tmp, entry('3'), 1000, minutes(300));
    put_file(tmp, entry('4'), 1000, minutes(200));
    put_file(tmp, entry('5'), 1000, minutes(100));  // newest
    put_file(tmp, "notes.txt", 100000, minutes(900));              // not ours: never touched
    put_file(tmp, "abc.clbin", 1000, minutes(900));                // not an entry name: never touched
    put_file(tmp, entry('6') + ".tmp.77.0", 1000, minutes(120));   // a writer that died
    put_file(tmp, entry('7') + ".tmp.78.0", 1000, minutes(1));     // a writer still at work

    SECTION("within the limit nothing but the dead writer's file goes") {
        CHECK(prune_program_cache(tmp.path.string(), 5000, name_of('5')) == 1);
        CHECK(names(tmp).size() == 8);
    }
    SECTION("over it, the oldest go first, and the entry in use stays however old") {
        CHECK(prune_program_cache(tmp.path.string(), 2500, name_of('1')) == 4);
        CHECK(names(tmp) == std::vector<std::string>{entry('1'), entry('5'), entry('7') + ".tmp.78.0", "abc.clbin",
                                                     "notes.txt"});
    }
    SECTION("a limit of 0 keeps the entry in use alone") {
        CHECK(prune_program_cache(tmp.path.string(), 0, name_of('3')) == 5);
        CHECK(names(tmp) == std::vector<std::string>{entry('3'), entry('7') + ".tmp.78.0", "abc.clbin", "notes.txt"});
    }
    SECTION("a load makes an entry the most recently used") {
        const std::string name = name_of('1');
        REQUIRE(store_program_binary(tmp.file(entry('1')), name, std::vector<unsigned char>(990, 7)));
        std::filesystem::last_write_time(tmp.file(entry('1')), std::filesystem::file_time_type::clock::now() - minutes(500));
        REQUIRE(load_program_binary(tmp.file(entry('1')), name));
        prune_program_cache(tmp.path.string(), 2500, name_of('5'));
        CHECK(names(tmp) == std::vector<std::string>{entry('1'), entry('5'), entry('7') + ".tmp.78.0", "abc.clbin",
                                                     "notes.txt"});
    }
    SECTION("a missing directory prunes nothing") {
        CHECK(prune_program_cache(tmp.file("absent"), 0, name_of('1')) == 0);
    }
}

TEST_CASE("the cache size limit comes from TRILEVEL_CACHE_MAX_MB when that is a size", "[program_cache]") {
    CHECK(program_cache_max_bytes() == kProgramCacheMaxBytes);
    {
        ScopedEnv env("TRILEVEL_CACHE_MAX_MB", "3");
        CHECK(program_cache_max_bytes() == 3u << 20);
    }
    {
        ScopedEnv env("TRILEVEL_CACHE_MAX_MB", "0");
        CHECK(program_cache_max_bytes() == 0);
    }
    for (const char* bad : {"", "-1", "12MB", "lots"}) {
        ScopedEnv env("TRILEVEL_CACHE_MAX_MB", bad);
        CHECK(program_cache_max_bytes() == kProgramCacheMaxBytes);
    }
}

TEST_CASE("program cache entries round-trip, and truncated, altered or foreign ones are refused", "[program_cache]") {
    TempDir tmp;
    const std::string path = tmp.file("sub/entry.clbin"), name = program_cache_name({"source", "options"});
    REQUIRE(name.size() == 16);
    CHECK(name == program_cache_name({"source", "options"}));
    CHECK(name != program_cache_name({"sourc", "eoptions"}));  // part boundaries count
    CHECK(name != program_cache_name({"source", "options", ""}));
    CHECK_FALSE(load_program_binary(path, name));  // nothing stored yet

    const std::vector<unsigned char> binary = {0, 1, 2, 3, 250, 251, 252, 253, 42};
    REQUIRE(store_program_binary(path, name, binary));  // creates the directory
    REQUIRE(load_program_binary(path, name) == binary);
    CHECK_FALSE(load_program_binary(path, program_cache_name({"other"})));
    REQUIRE(entries(tmp).size() == 1);  // no temporary file left beside it

    const std::string good = slurp(path);
    std::string bad = good;
    bad.pop_back();
    write_bytes(path, bad);
    CHECK_FALSE(load_program_binary(path, name));  // truncated
    bad = good;
    bad.back() ^= 1;
    write_bytes(path, bad);
    CHECK_FALSE(load_program_binary(path, name));  // payload changed: checksum
    bad = good;
    bad[0] ^= 1;
    write_bytes(path, bad);
    CHECK_FALSE(load_program_binary(path, name));  // not our format
    write_bytes(path, good);
    CHECK(load_program_binary(path, name) == binary);
}

TEST_CASE("a runtime loads its program from the disk cache and meshes as one built from source",
          "[program_cache][device]") {
    TempDir tmp;
    ParticleSet s = generate_scene("pool-and-drop", 0.025f, 2);
    Params p;
    p.particle_radius = 0.025f;
    Mesh from_source;
    {
        ScopedEnv off("TRILEVEL_CACHE_DIR", "");  // caching off: always from source
        Reconstructor rec;
        from_source = rec.reconstruct(s.positions.data(), s.size(), p);
    }
    ScopedEnv env("TRILEVEL_CACHE_DIR", tmp.path.c_str());
    {
        OpenCLRuntime first(-1);
        CHECK_FALSE(first.program_from_cache());
    }
    const auto stored = entries(tmp);
    REQUIRE(stored.size() == 1);
    CHECK(stored[0].extension() == ".clbin");
    OpenCLRuntime second(-1);
    CHECK(second.program_from_cache());
    Reconstructor cached;
    REQUIRE(same_mesh(from_source, cached.reconstruct(s.positions.data(), s.size(), p)));

    SECTION("an entry the driver rejects is rebuilt from source and replaced") {
        const std::string path = stored[0].string(), name = stored[0].stem().string();
        REQUIRE(store_program_binary(path, name, std::vector<unsigned char>(4096, 0x5a)));  // intact, not a program
        OpenCLRuntime rebuilt(-1);
        CHECK_FALSE(rebuilt.program_from_cache());
        OpenCLRuntime again(-1);
        CHECK(again.program_from_cache());
        REQUIRE(entries(tmp).size() == 1);
    }
    SECTION("a runtime that stores an entry prunes the directory to the limit") {
        put_file(tmp, entry('a'), 4096, std::chrono::minutes(60));  // another driver's entry, say
        const std::string path = stored[0].string(), name = stored[0].stem().string();
        REQUIRE(store_program_binary(path, name, std::vector<unsigned char>(4096, 0x5a)));  // forces a rebuild
        ScopedEnv limit("TRILEVEL_CACHE_MAX_MB", "0");
        OpenCLRuntime rebuilt(-1);
        CHECK_FALSE(rebuilt.program_from_cache());
        REQUIRE(entries(tmp) == stored);  // the other entry went, its own stayed
    }
}
