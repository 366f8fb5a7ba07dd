// The CLI under failure: absurd parameters and OpenCL failures are one stderr line, a
// non-zero exit and no output; a process killed while writing leaves the previous output intact
// and no partial file.
#include <chrono>
#include <csignal>
#include <fstream>
#include <set>
#include <sstream>
#include <thread>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cli_test_support.hpp"
#include "trilevel/io.hpp"

extern char** environ;

using trilevel::test::TempDir;
using trilevel::test::slurp;
namespace fs = std::filesystem;

namespace {

std::set<std::string> listing(const fs::path& dir) {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
    return names;
}

/// Starts the CLI with `args` and extra environment entries ("NAME=value"); stdout/stderr to files.
pid_t spawn_cli(const std::vector<std::string>& args, const std::vector<std::string>& env, const std::string& out,
                const std::string& err) {
    std::vector<std::string> argv_s = {TRILEVEL_CLI};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> env_s = env;
    for (char** e = environ; *e; ++e) env_s.emplace_back(*e);
    std::vector<char*> envp;
    for (auto& e : env_s) envp.push_back(e.data());
    envp.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid = -1;
    const int rc = posix_spawn(&pid, TRILEVEL_CLI, &fa, nullptr, argv.data(), envp.data());
    posix_spawn_file_actions_destroy(&fa);
    REQUIRE(rc == 0);
    return pid;
}

struct Finished {
    int exit_code = -1;  // when it exited
    int signal = 0;      // when a signal ended it
    std::string err;
};

Finished wait_cli(pid_t pid, const std::string& err_file) {
    int status = 0;
    REQUIRE(waitpid(pid, &status, 0) == pid);
    Finished f;
    if (WIFEXITED(status)) f.exit_code = WEXITSTATUS(status);
    if (WIFSIGNALED(status)) f.signal = WTERMSIG(status);
    f.err = trilevel::test::without_compile_notice(slurp(err_file));  // a cold start's notice
    return f;
}

Finished run_cli(const TempDir& tmp, const std::vector<std::string>& args, const std::vector<std::string>& env = {}) {
    const std::string out = tmp.file("stdout.txt"), err = tmp.file("stderr.txt");
    return wait_cli(spawn_cli(args, env, out, err), err);
}

/// Does process `pid` hold a file open in `dir` (an unnamed O_TMPFILE shows as "dir/#123 (deleted)")?
bool writing_into(pid_t pid, const fs::path& dir) {
    std::error_code ec;
    const std::string prefix = dir.string() + "/";
    for (const auto& e : fs::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec)) {
        const fs::path target = fs::read_symlink(e.path(), ec);
        if (!ec && target.string().rfind(prefix, 0) == 0) return true;
    }
    return false;
}

void require_one_line_error(const Finished& f, const std::string& what) {
    INFO("stderr: " << f.err);
    CHECK(f.exit_code > 0);
    CHECK(f.err.rfind("trilevel: error: ", 0) == 0);
    CHECK(std::count(f.err.begin(), f.err.end(), '\n') == 1);
    CHECK(f.err.find(what) != std::string::npos);
}

}  // namespace

TEST_CASE("CLI: absurd parameters are one line naming the parameter, and the old output stays", "[cli][robust]") {
    TempDir tmp;
    const std::string in = tmp.file("in.xyz"), out = tmp.file("out.ply");
    trilevel::write_particles(in, trilevel::generate_scene("pool-and-drop", 0.025f));
    { std::ofstream(out) << "previous output"; }
    const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
        {{"-r", "0"}, "radius (-r) must be > 0"},
        {{"-r", "-0.025"}, "radius (-r) must be > 0"},
        {{"-r", "nan"}, "radius (-r) must be finite"},
        {{"-r", "inf"}, "radius (-r) must be finite"},
        {{"-r", "1e30"}, "particle radius 1e+30"},
        {{"-r", "1e-30"}, "particle radius 1e-30"},
        {{"-r", "1e-30"}, "cannot resolve"},
        {{"-r", "1e3"}, "too large for these particles"},
        {{"-r", "0.025", "--kernel-radius", "0"}, "kernel radius (--kernel-radius) must be > 0"},
        {{"-r", "0.025", "--kernel-radius", "nan"}, "kernel radius (--kernel-radius) must be finite"},
        {{"-r", "0.025", "--kernel-radius", "100"}, "kernel radius (--kernel-radius) must lie in [1, 16] particle radii, got '100'"},
        {{"-r", "0.025", "--kernel-radius", "0x10"}, "kernel radius (--kernel-radius) must be a number, got '0x10'"},
        {{"-r", "0.025", "--kernel-radius", "16.0001"}, "kernel radius (--kernel-radius) must lie in [1, 16] particle radii, got '16.0001'"},
        {{"-r", "0.025", "--mode", "uniform", "--cell", "3"}, "cell (--cell) 3 must be 4/n radii for an even n from 2 to 64"},
        {{"-r", "0.025", "--mode", "uniform", "--cell", "4"}, "cell (--cell) 4 must be 4/n radii"},
        {{"-r", "0.025", "--mode", "uniform", "--cell", "0.8"}, "cell (--cell) 0.8 must be 4/n radii"},
        {{"-r", "0.025", "--mode", "uniform", "--cell", "0.03125"}, "cell (--cell) 0.03125 must be 4/n radii"},
        {{"-r", "0.025", "--mode", "uniform", "--cell", "-1"}, "cell (--cell) must be > 0"},
        {{"-r", "0.025", "--mode", "uniform", "--cell", "inf"}, "cell (--cell) must be finite"},
        {{"-r", "0.025", "--curvature-threshold", "0"}, "curvature threshold (--curvature-threshold) must be > 0"},
        {{"-r", "0.025", "--curvature-threshold", "-inf"}, "curvature threshold (--curvature-threshold) must be finite"},
        {{"-r", "0.025", "--level2-tolerance", "-1"}, "--level2-tolerance must be >= 0"},
        {{"-r", "0.025", "--level2-tolerance", "nan"}, "--level2-tolerance must be >= 0"},
        {{"-r", "0.025", "--level2-tolerance", "1e30"}, "--level2-tolerance must be >= 0 and below 1e6"},
        {{"-r", "0.025", "--crack-closing", "weld"}, "--crack-closing must be collapse or patches, got 'weld'"},
        {{"-r", "0.025", "--memory-limit", "1"}, "memory limit of 1 bytes"},
        {{"-r", "0.025", "--memory-limit", "0"}, "--memory-limit must be a positive byte count"},
        {{"-r", "0.025", "--memory-limit", "64K"}, "over the budget"},
    };
    for (const auto& [extra, what] : cases) {
        std::vector<std::string> args = {"reconstruct", in, "-o", out};
        args.insert(args.end(), extra.begin(), extra.end());
        INFO(extra.back());
        require_one_line_error(run_cli(tmp, args), what);
        CHECK(slurp(out) == "previous output");
    }
    CHECK(listing(tmp.path) == std::set<std::string>{"in.xyz", "out.ply", "stdout.txt", "stderr.txt"});
    std::printf("absurd parameter sets rejected through the CLI: %zu\n", cases.size());
}

TEST_CASE("CLI: OpenCL failures and a missing platform are one line, with no output written", "[cli][robust]") {
    TempDir tmp;
    const std::string in = tmp.file("in.xyz"), out = tmp.file("out.ply");
    trilevel::write_particles(in, trilevel::generate_scene("pool-and-drop", 0.025f));
    { std::ofstream(out) << "previous output"; }
    for (const char* stage : {"binning", "surface_cells", "scalar_field", "triangulation"}) {
        INFO(stage);
        const Finished f = run_cli(tmp, {"reconstruct", in, "-o", out, "-r", "0.025"}, {std::string("TRILEVEL_FAULT=") + stage});
        require_one_line_error(f, std::string("OpenCL failure in stage ") + stage + ": ");
        CHECK(f.err.find("CL_OUT_OF_RESOURCES") != std::string::npos);
        CHECK(slurp(out) == "previous output");
    }
    const fs::path empty = tmp.path / "no-vendors";
    fs::create_directory(empty);
    for (const std::vector<std::string>& args :
         {std::vector<std::string>{"devices"}, std::vector<std::string>{"reconstruct", in, "-o", out, "-r", "0.025"}}) {
        // ocl-icd reads its driver list from OCL_ICD_VENDORS: an empty directory is a machine without OpenCL.
        const Finished f = run_cli(tmp, args, {"OCL_ICD_VENDORS=" + empty.string()});
        require_one_line_error(f, "no OpenCL platform found");
    }
    CHECK(slurp(out) == "previous output");
    CHECK(listing(tmp.path) == std::set<std::string>{"in.xyz", "out.ply", "stdout.txt", "stderr.txt", "no-vendors"});
}

TEST_CASE("CLI: a process killed while writing leaves the previous output intact and no partial file",
          "[cli][robust][kill]") {
    TempDir tmp;
    const fs::path work = tmp.path / "out";  // the target directory holds nothing but the output
    fs::create_directory(work);
    const std::string in = tmp.file("in.xyz"), target = (work / "mesh.obj").string();
    trilevel::write_particles(in, trilevel::generate_scene("pool-and-drop", 0.025f));
    const std::vector<std::string> args = {"reconstruct", in, "-q", "-o", target, "-r", "0.025", "--mode", "uniform", "--cell", "1"};
    REQUIRE(run_cli(tmp, args).exit_code == 0);
    const std::string complete = slurp(target);  // what a finished run writes (runs are bit-identical)
    REQUIRE(complete.size() > 1000000);
    const std::string previous = "previous output\n";

    struct Kill {
        int signal;
        int delay_ms;         // after start, or (< 0) after the output file was seen open: -1 - ms
        bool named = false;   // TRILEVEL_NO_TMPFILE=1: the named-temporary path of file systems without O_TMPFILE
    };
    const std::vector<Kill> kills = {{SIGKILL, 50},  {SIGKILL, 300},   {SIGKILL, -1},        {SIGKILL, -3},
                                     {SIGKILL, -11}, {SIGTERM, -1},    {SIGINT, -2},         {SIGTERM, -1, true},
                                     {SIGINT, -3, true}, {SIGKILL, -2, true}};
    int mid_write = 0;
    for (const Kill& k : kills) {
        INFO("signal " << k.signal << ", delay " << k.delay_ms << (k.named ? ", named temporary" : ""));
        { std::ofstream(target, std::ios::binary) << previous; }
        const std::vector<std::string> env = k.named ? std::vector<std::string>{"TRILEVEL_NO_TMPFILE=1"} : std::vector<std::string>{};
        const pid_t pid = spawn_cli(args, env, tmp.file("stdout.txt"), tmp.file("stderr.txt"));
        bool seen = false;
        if (k.delay_ms >= 0) {
            std::this_thread::sleep_for(std::chrono::milliseconds(k.delay_ms));
        } else {
            int status = 0;
            while (!(seen = writing_into(pid, work)) && waitpid(pid, &status, WNOHANG) == 0) ::usleep(100);
            if (!seen) {  // finished before we saw it write: nothing to kill
                CHECK(slurp(target) == complete);
                continue;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(-1 - k.delay_ms));
        }
        const bool still_writing = seen && writing_into(pid, work);
        ::kill(pid, k.signal);
        const Finished f = wait_cli(pid, tmp.file("stderr.txt"));
        const std::string now = slurp(target);
        CHECK((now == previous || now == complete));
        if (f.signal == 0) {  // it finished before the signal arrived
            CHECK(now == complete);
            continue;
        }
        CHECK(f.signal == k.signal);
        mid_write += still_writing;
        std::set<std::string> left = listing(work);
        left.erase("mesh.obj");
        if (k.named && k.signal == SIGKILL) {
            // Documented: without O_TMPFILE a SIGKILL can leave the named temporary, hidden and never
            // under the target's name.
            for (const auto& name : left) {
                CHECK(name.rfind(".mesh.obj.tmp." + std::to_string(pid) + ".", 0) == 0);
                fs::remove(work / name);
            }
        } else {
            // Only a SIGKILL in the microseconds between linking the finished file and renaming it
            // can leave a temporary here, and that one is complete.
            for (const auto& name : left) {
                CHECK(k.signal == SIGKILL);
                CHECK(name.rfind(".mesh.obj.tmp." + std::to_string(pid) + ".", 0) == 0);
                CHECK(slurp((work / name).string()) == complete);
                fs::remove(work / name);
            }
        }
    }
    std::printf("kills that landed while the output was being written: %d of %zu\n", mid_write, kills.size());
    CHECK(mid_write >= 3);
}
