// The first run says what it does: a cold start compiles the OpenCL kernels (seconds on PoCL), which
// the Reconstructor announces (KernelCompileNotice) and the CLI prints once on stderr; the
// statistics give that time apart ("kernel_compile", or "kernel_load" from the program cache).
#include <catch2/catch.hpp>

#include <algorithm>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"
#include "trilevel/trilevel.hpp"

using namespace trilevel;
using trilevel::test::CliResult;
using trilevel::test::run_cli_raw;
using trilevel::test::ScopedEnv;
using trilevel::test::slurp;
using trilevel::test::TempDir;

namespace {

/// The names of the time_ms entries that precede the pipeline stages.
std::vector<std::string> build_entries(const Stats& s) {
    std::vector<std::string> out;
    for (const auto& [name, ms] : s.time_ms)
        if (name.rfind("kernel_", 0) == 0) out.push_back(name);
    return out;
}

}  // namespace

TEST_CASE("a Reconstructor announces a compile from source, and the statistics time it apart", "[first_run][device]") {
    TempDir cache;
    ScopedEnv env("TRILEVEL_CACHE_DIR", cache.path.c_str());
    const ParticleSet s = generate_scene("sphere", 0.05f, 2);
    Params p;
    p.particle_radius = 0.05f;
    std::vector<KernelCompileNotice> notices;
    const auto note = [&](const KernelCompileNotice& n) { notices.push_back(n); };

    Reconstructor cold(-1, note);  // an empty cache: compiled from source
    REQUIRE(notices.size() == 1);
    CHECK(notices[0].device == cold.device().name);
    CHECK(notices[0].cache_dir == cache.path.string());
    Stats st;
    cold.reconstruct(s.positions.data(), s.size(), p, &st);
    CHECK(build_entries(st) == std::vector<std::string>{"kernel_compile"});
    CHECK(st.time_ms.front().first == "kernel_compile");
    CHECK(st.time_ms.front().second > 0);
    CHECK(st.time_ms.back().first == "total");
    cold.reconstruct(s.positions.data(), s.size(), p, &st);  // the next frame built nothing
    CHECK(build_entries(st).empty());

    Reconstructor warm(-1, note);  // the program is cached now: loaded, no notice
    CHECK(notices.size() == 1);
    warm.reconstruct(s.positions.data(), s.size(), p, &st);
    CHECK(build_entries(st) == std::vector<std::string>{"kernel_load"});
    CHECK(st.time_ms.front().first == "kernel_load");
    const std::string json = stats_to_json(st, p);
    CHECK(json.find("\"kernel_load\"") != std::string::npos);
    CHECK(json.find("\"kernel_compile\"") == std::string::npos);
}

TEST_CASE("the CLI says once that it compiles the kernels unless quiet, and --stats separates that time", "[first_run][cli]") {
    TempDir tmp, cache, quiet_cache;
    REQUIRE(run_cli_raw(tmp, "generate falling-drop -o '" + tmp.file("d_{}.xyz") + "' --radius 0.05 --frames 3").code == 0);
    const std::string args = "reconstruct '" + tmp.file("d_{}.xyz") + "' -r 0.05 -o '" + tmp.file("m_{}.ply") +
                             "' --stats '" + tmp.file("s_{}.json") + "'";
    std::string device;
    {
        ScopedEnv env("TRILEVEL_CACHE_DIR", quiet_cache.path.c_str());
        const CliResult cold = run_cli_raw(tmp, args + " -q");  // -q prints nothing on success, this either
        REQUIRE(cold.code == 0);
        CHECK(cold.err.empty());
        CHECK(cold.out.empty());
        CHECK(slurp(tmp.file("s_0000.json")).find("\"kernel_compile\"") != std::string::npos);  // it did compile
    }
    {
        ScopedEnv env("TRILEVEL_CACHE_DIR", cache.path.c_str());
        const CliResult cold = run_cli_raw(tmp, args);  // three frames, one Reconstructor: said once
        REQUIRE(cold.code == 0);
        const std::string first = slurp(tmp.file("s_0000.json"));
        const auto at = first.find("\"device\": \"");
        REQUIRE(at != std::string::npos);
        device = first.substr(at + 11, first.find('"', at + 11) - at - 11);
        CHECK(cold.err == "trilevel: compiling OpenCL kernels for " + device + " (once; cached in " + cache.path.string() + ")\n");
        CHECK(first.find("\"kernel_compile\"") != std::string::npos);
        const std::string second = slurp(tmp.file("s_0001.json"));  // later frames built nothing
        CHECK(second.find("\"kernel_compile\"") == std::string::npos);
        CHECK(second.find("\"kernel_load\"") == std::string::npos);

        const CliResult warm = run_cli_raw(tmp, args);  // the cache holds the program now: no notice
        REQUIRE(warm.code == 0);
        CHECK(warm.err.empty());
        const std::string again = slurp(tmp.file("s_0000.json"));
        CHECK(again.find("\"kernel_load\"") != std::string::npos);
        CHECK(again.find("\"kernel_compile\"") == std::string::npos);
    }
    ScopedEnv off("TRILEVEL_CACHE_DIR", "");  // caching off: compiled on every start, and it says so
    const CliResult uncached = run_cli_raw(tmp, "reconstruct '" + tmp.file("d_0000.xyz") + "' -r 0.05 -o '" + tmp.file("u.ply") + "'");
    REQUIRE(uncached.code == 0);
    CHECK(uncached.err == "trilevel: compiling OpenCL kernels for " + device +
                              " (on every start: caching is off, see TRILEVEL_CACHE_DIR)\n");
}
