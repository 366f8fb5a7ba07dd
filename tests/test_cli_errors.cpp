// The CLI: every failure is one stderr line "trilevel: error: ...", a non-zero exit code and no
// output file; successful runs write closed meshes, bit-identical run after run.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#if defined(__linux__)
#include <sched.h>
#endif
#include <sys/wait.h>

#include "cli_test_support.hpp"
#include "trilevel/io.hpp"

using trilevel::test::TempDir;
using trilevel::test::CliResult;
using trilevel::test::run_cli;
using trilevel::test::slurp;

namespace {

/// The command must fail with exactly one "trilevel: error:" line, and `output` must not exist.
void require_cli_error(const TempDir& tmp, const std::string& args, const std::string& output, const std::string& what) {
    INFO("trilevel " << args);
    const CliResult r = run_cli(tmp, args);
    INFO("stderr: " << r.err);
    CHECK(r.code != 0);
    CHECK(r.err.rfind("trilevel: error: ", 0) == 0);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK(r.err.back() == '\n');
    CHECK(r.err.find(what) != std::string::npos);
    if (!output.empty()) CHECK_FALSE(std::filesystem::exists(output));
}

}  // namespace

TEST_CASE("CLI: a mesh that would overwrite its input is refused and the input kept", "[cli]") {
    TempDir tmp;
    const std::string in = tmp.file("in.ply");
    trilevel::write_particles(in, trilevel::generate_scene("block", 0.025f));
    const std::string before = slurp(in);
    for (const std::string& out : {in, tmp.file("./in.ply"), tmp.file("sub/../in.ply")}) {
        std::filesystem::create_directories(tmp.file("sub"));
        require_cli_error(tmp, "reconstruct '" + in + "' -o '" + out + "' -r 0.025", "", "would overwrite the input");
    }
    std::filesystem::create_symlink(in, tmp.file("link.ply"));
    require_cli_error(tmp, "reconstruct '" + in + "' -o '" + tmp.file("link.ply") + "' -r 0.025", "", "the mesh " + tmp.file("link.ply") + " would overwrite the input");
    for (const char* frame : {"f_0001.ply", "f_0002.ply"}) std::filesystem::copy_file(in, tmp.file(frame));
    require_cli_error(tmp, "reconstruct '" + tmp.file("f_{}.ply") + "' -o '" + tmp.file("f_{}.ply") + "' -r 0.025", "",
                      "frame 0001: the mesh " + tmp.file("f_0001.ply") + " would overwrite the input");
    CHECK(slurp(in) == before);
    CHECK(slurp(tmp.file("f_0001.ply")) == before);
}

TEST_CASE("CLI: reconstruct rejects bad inputs and parameters before writing anything", "[cli]") {
    TempDir tmp;
    const std::string in = tmp.file("in.xyz"), out = tmp.file("out.ply");
    trilevel::write_particles(in, trilevel::generate_scene("block", 0.025f));
    trilevel::ParticleSet nan;
    nan.positions = {0, 0, 0, 1, NAN, 1};
    trilevel::write_particles(tmp.file("ok.ply"), {});
    {
        std::ofstream f(tmp.file("nan.xyz"), std::ios::binary);
        f.write(reinterpret_cast<const char*>(nan.positions.data()), 24);
    }
    const std::string base = "reconstruct '" + in + "' -o '" + out + "' ";
    require_cli_error(tmp, "reconstruct '" + tmp.file("absent.vtk") + "' -o '" + out + "' -r 0.025", out, "absent.vtk: no such file");
    require_cli_error(tmp, "reconstruct '" + tmp.file("nan.xyz") + "' -o '" + out + "' -r 0.025", out, "non-finite");
    require_cli_error(tmp, "reconstruct '" + tmp.path.string() + "' -o '" + out + "' -r 0.025", out, "");
    require_cli_error(tmp, base + "-r 0", out, "radius (-r) must be > 0");
    require_cli_error(tmp, base + "-r -1", out, "radius (-r) must be > 0");
    require_cli_error(tmp, base + "-r nan", out, "radius (-r) must be finite");
    require_cli_error(tmp, base + "-r inf", out, "radius (-r) must be finite");
    require_cli_error(tmp, base + "-r abc", out, "radius (-r) must be a number");
    require_cli_error(tmp, base + "-r 1e60", out, "float range");
    require_cli_error(tmp, base + "-r 0.025 --cell 3", out, "must be 4/n radii for an even n from 2 to 64");
    require_cli_error(tmp, base + "-r 0.025 --cell 0", out, "cell (--cell) must be > 0");
    require_cli_error(tmp, base + "-r 0.025 --kernel-radius -4", out, "kernel radius");
    require_cli_error(tmp, base + "-r 0.025 --curvature-threshold nan", out, "curvature threshold");
    require_cli_error(tmp, base + "-r 0.025 --mode fancy", out, "--mode must be adaptive or uniform");
    require_cli_error(tmp, base + "-r 0.025 --memory-limit 2Q", out, "--memory-limit");
    require_cli_error(tmp, base + "-r 0.025 --threads 0", out, "--threads must be a whole number");
    require_cli_error(tmp, base + "-r 0.025 --threads -2", out, "--threads");
    require_cli_error(tmp, base + "-r 0.025 --threads two", out, "--threads must be a whole number");
    require_cli_error(tmp, base + "-r 0.025 --device=-2", out, "--device must be a device index (0, 1, ...; see 'trilevel devices'), got -2");
    require_cli_error(tmp, base + "-r 0.025 --device 99", out, "OpenCL device 99 does not exist");
    require_cli_error(tmp, base, out, "radius");
    require_cli_error(tmp, "reconstruct '" + in + "' -o '" + tmp.file("missing/out.ply") + "' -r 0.025", tmp.file("missing/out.ply"),
                      "does not exist");
    require_cli_error(tmp, "reconstruct '" + in + "' -o '" + tmp.file("out.stl") + "' -r 0.025", tmp.file("out.stl"),
                      "unknown mesh extension 'stl', expected .ply, .obj, .vtk, .vtp, .vtu");
    require_cli_error(tmp, base + "-r 0.025 --stats '" + tmp.file("missing/s.json") + "'", out, "does not exist");
}

TEST_CASE("CLI: bad smoothing options give one exact usage line and exit 2", "[cli][smoothing]") {
    TempDir tmp;
    const std::string in = tmp.file("in.xyz"), out = tmp.file("out.ply");
    trilevel::write_particles(in, trilevel::generate_scene("block", 0.025f));
    const std::string base = "reconstruct '" + in + "' -o '" + out + "' -r 0.025 ";
    for (const char* bad : {"0", "-3", "1001", "2.5", "ten"}) {
        const std::string value = bad;
        const CliResult r = run_cli(tmp, base + "--smooth-iterations " + bad);
        INFO("--smooth-iterations " << bad << ": " << r.err);
        CHECK(r.code == 2);
        CHECK(r.err == "trilevel: error: --smooth-iterations must be a whole number from 1 to 1000, got '" + value + "'\n");
        CHECK_FALSE(std::filesystem::exists(out));
    }
}

TEST_CASE("CLI: generate, info and usage errors", "[cli]") {
    TempDir tmp;
    const std::string out = tmp.file("scene.ply");
    require_cli_error(tmp, "generate teapot -o '" + out + "' --radius 0.025", out, "unknown scene 'teapot'");
    require_cli_error(tmp, "generate block -o '" + out + "' --radius 0", out, "radius");
    require_cli_error(tmp, "generate block -o '" + tmp.file("missing/s.ply") + "' --radius 0.025", tmp.file("missing/s.ply"), "does not exist");
    require_cli_error(tmp, "generate block -o '" + tmp.file("s.obj") + "' --radius 0.025", tmp.file("s.obj"), "extension");
    require_cli_error(tmp, "info '" + tmp.file("absent.bgeo") + "'", "", "absent.bgeo");
    require_cli_error(tmp, "", "", "");
    require_cli_error(tmp, "frobnicate", "", "");
    require_cli_error(tmp, "reconstruct --no-such-option", "", "");
}

TEST_CASE("CLI: generate and info succeed on good input", "[cli]") {
    TempDir tmp;
    const std::string out = tmp.file("scene.vtk");
    const CliResult g = run_cli(tmp, "generate sphere -o '" + out + "' --radius 0.05 --seed 3");
    REQUIRE(g.code == 0);
    CHECK(g.err.empty());
    CHECK(g.out.find("14328 particles") != std::string::npos);
    REQUIRE(trilevel::read_particles(out).size() == 14328);
    const CliResult i = run_cli(tmp, "info '" + out + "'");
    REQUIRE(i.code == 0);
    CHECK(i.out.find("particles: 14328") != std::string::npos);
    const auto at = i.out.find("spacing: ");
    REQUIRE(at != std::string::npos);
    const double spacing = std::atof(i.out.c_str() + at + 9);
    CHECK(spacing > 0.09);  // 2r = 0.1, less a few percent of jitter
    CHECK(spacing < 0.11);
}

TEST_CASE("CLI: frame sequences need '{}' in the output and at least one frame", "[cli]") {
    TempDir tmp;
    const std::string out = tmp.file("m_{}.ply");
    require_cli_error(tmp, "reconstruct '" + tmp.file("f_{}.xyz") + "' -o '" + out + "' -r 0.025", "", "no frame files match");
    trilevel::write_particles(tmp.file("f_3.xyz"), trilevel::generate_scene("block", 0.025f));
    require_cli_error(tmp, "reconstruct '" + tmp.file("f_{}.xyz") + "' -o '" + tmp.file("m.ply") + "' -r 0.025", tmp.file("m.ply"),
                      "-o must contain '{}'");
    CHECK_FALSE(std::filesystem::exists(tmp.file("m_3.ply")));
}

TEST_CASE("CLI: reconstruct writes a closed mesh and statistics for a small block", "[cli]") {
    TempDir tmp;
    trilevel::ParticleSet block;
    for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j)
            for (int k = 0; k < 8; ++k) block.positions.insert(block.positions.end(), {i * 0.05f, j * 0.05f, k * 0.05f});
    trilevel::write_particles(tmp.file("b.ply"), block);
    const CliResult r = run_cli(tmp, "reconstruct '" + tmp.file("b.ply") + "' -o '" + tmp.file("m.vtk") + "' -r 0.025 --stats '" +
                                         tmp.file("s.json") + "'");
    INFO(r.err);
    REQUIRE(r.code == 0);
    CHECK(r.out.find("particles: 512") != std::string::npos);
    const auto mesh = trilevel::read_mesh(tmp.file("m.vtk"));
    CHECK(mesh.triangle_count() > 0);
    CHECK(trilevel::is_closed_and_oriented(mesh));
    CHECK(slurp(tmp.file("s.json")).find("\"particles\"") != std::string::npos);
}

TEST_CASE("CLI: two runs write bit-identical mesh files", "[cli][determinism]") {
    TempDir tmp;
    REQUIRE(run_cli(tmp, "generate pool-and-drop -o '" + tmp.file("p.xyz") + "' --radius 0.025 --seed 4").code == 0);
    for (const char* mode : {"--mode adaptive", "--mode uniform --cell 1", "--mode uniform --cell 2"}) {
        INFO(mode);
        for (const char* out : {"a.ply", "b.ply"})
            REQUIRE(run_cli(tmp, "reconstruct '" + tmp.file("p.xyz") + "' -r 0.025 " + mode + " -q -o '" + tmp.file(out) + "'")
                        .code == 0);
        const std::string a = slurp(tmp.file("a.ply")), b = slurp(tmp.file("b.ply"));
        REQUIRE(a.size() > 1000);
        REQUIRE(a == b);
        // One thread for the host stages and PoCL: other chunks per thread, the same bits (docs/design.md §6).
        REQUIRE(run_cli(tmp, "reconstruct '" + tmp.file("p.xyz") + "' -r 0.025 " + mode + " -q --threads 1 -o '" +
                                 tmp.file("c.ply") + "' --stats '" + tmp.file("c.json") + "'")
                    .code == 0);
        REQUIRE(slurp(tmp.file("c.ply")) == a);
        const std::string stats = slurp(tmp.file("c.json"));
        CHECK(stats.find("\"host\": 1,") != std::string::npos);  // the limit reached the host stages
        // and PoCL (a GPU keeps its compute units)
        if (stats.find("\"device\": \"pthread-") != std::string::npos || stats.find("\"device\": \"cpu-") != std::string::npos)
            CHECK(stats.find("\"device_compute_units\": 1\n") != std::string::npos);
    }
}

TEST_CASE("CLI: PoCL's threads are pinned only when the process has the first CPUs to itself", "[cli][determinism]") {
#if defined(__linux__)
    // The CLI sets POCL_AFFINITY=1 (thread i on CPU i) only when it may run on CPUs 0 .. m-1 and
    // nothing else; under another CPU set PoCL would move its threads off the CPUs given. Each run
    // must succeed with the same bits; a pinned run has one PoCL thread per CPU given.
    cpu_set_t allowed;
    CPU_ZERO(&allowed);
    REQUIRE(::sched_getaffinity(0, sizeof(allowed), &allowed) == 0);
    if (std::system("taskset -c 0 true >/dev/null 2>&1") != 0 || !CPU_ISSET(0, &allowed) || CPU_COUNT(&allowed) < 2) {
        WARN("SKIPPED: needs util-linux `taskset` and CPU 0 and another");
        return;
    }
    int other = 1;
    while (!CPU_ISSET(other, &allowed)) ++other;
    TempDir tmp;
    REQUIRE(run_cli(tmp, "generate falling-drop -o '" + tmp.file("p.xyz") + "' --radius 0.025 --seed 2").code == 0);
    const std::string base = "reconstruct '" + tmp.file("p.xyz") + "' -r 0.025 -q ";
    REQUIRE(run_cli(tmp, base + "-o '" + tmp.file("all.ply") + "'").code == 0);
    const std::string all = slurp(tmp.file("all.ply"));
    REQUIRE(all.size() > 1000);
    const auto units = [&](const std::string& json) {
        const std::string s = slurp(tmp.file(json)), key = "\"device_compute_units\": ";
        const auto at = s.find(key);
        return at == std::string::npos ? -1 : std::atoi(s.c_str() + at + key.size());
    };
    REQUIRE(run_cli(tmp, base + "-o '" + tmp.file("x.ply") + "' --stats '" + tmp.file("x.json") + "'").code == 0);
    const std::string unrestricted = slurp(tmp.file("x.json"));
    const bool pocl = unrestricted.find("\"device\": \"pthread-") != std::string::npos ||
                      unrestricted.find("\"device\": \"cpu-") != std::string::npos;
    struct Run {
        std::string prefix, name;
        int units;  // PoCL threads expected; 0: PoCL's own choice, which depends on its version
    };
    const std::vector<Run> runs = {
        {"taskset -c 0 '", "first", 1},                               // CPU 0 only: pinned, one thread
        {"taskset -c " + std::to_string(other) + " '", "other", 0},   // not the first CPU: left alone
        {"POCL_AFFINITY=0 taskset -c 0 '", "user", 0},                // the user's setting stays
        {"POCL_MAX_PTHREAD_COUNT=1 '", "count", 1}};                  // and the user's thread count
    for (const Run& r : runs) {
        INFO(r.name);
        const std::string cmd = r.prefix + TRILEVEL_CLI + "' " + base + "-o '" + tmp.file(r.name + ".ply") + "' --stats '" +
                                tmp.file(r.name + ".json") + "' >/dev/null 2>&1";
        REQUIRE(std::system(cmd.c_str()) == 0);
        REQUIRE(slurp(tmp.file(r.name + ".ply")) == all);
        if (pocl && r.units > 0) CHECK(units(r.name + ".json") == r.units);
    }
#else
    WARN("SKIPPED: CPU affinity (taskset, POCL_AFFINITY) is Linux-only");
#endif
}
