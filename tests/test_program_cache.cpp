// The on-disk cache of program binaries (src/program_cache.hpp): entries round-trip, damaged or
// foreign ones are refused, and a runtime built from a cached binary meshes like one built from
// source.
#include <filesystem>
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

}  // namespace

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
}
