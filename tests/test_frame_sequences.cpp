// Frame sequences in the CLI: "{}" with any padding, numeric order, --start/--end, resuming with
// --skip-existing, a failing frame that does not stop the run, and a 200-frame generated sequence.
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <sys/wait.h>

#include "cli_test_support.hpp"
#include "trilevel/io.hpp"

using trilevel::test::TempDir;
using trilevel::test::CliResult;
using trilevel::test::run_cli;
using trilevel::test::slurp;

namespace {

/// A 6 x 6 x 6 block of particles (spacing 2r, r = 0.025) moved by `shift` along x.
trilevel::ParticleSet small_block(float shift) {
    trilevel::ParticleSet s;
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j)
            for (int k = 0; k < 6; ++k) s.positions.insert(s.positions.end(), {shift + i * 0.05f, j * 0.05f, k * 0.05f});
    return s;
}

/// The frame numbers of the "frame N [" progress lines, in the order printed.
std::vector<std::string> frames_printed(const std::string& out) {
    std::vector<std::string> frames;
    std::istringstream in(out);
    for (std::string line; std::getline(in, line);)
        if (line.rfind("frame ", 0) == 0) frames.push_back(line.substr(6, line.find(' ', 6) - 6));
    return frames;
}

/// Frame numbers as `trilevel generate --frames` writes them: 4 digits.
std::string padded(int f) {
    std::string s = std::to_string(f);
    return std::string(4 - std::min<std::size_t>(4, s.size()), '0') + s;
}

bool closed_mesh(const std::string& path) {
    const trilevel::Mesh m = trilevel::read_mesh(path);
    return m.triangle_count() > 0 && trilevel::is_closed_and_oriented(m);
}

}  // namespace

TEST_CASE("CLI sequences: any zero padding, numeric order, outputs named like the inputs, --start/--end", "[cli][sequence]") {
    TempDir tmp;
    for (const char* n : {"10", "2", "0007", "1"}) trilevel::write_particles(tmp.file(std::string("f_") + n + ".xyz"), small_block(0.01f * std::atoi(n)));
    trilevel::write_particles(tmp.file("f_x3.xyz"), small_block(0));  // not a frame number: ignored
    const std::string in = "'" + tmp.file("f_{}.xyz") + "'", out = " -o '" + tmp.file("m_{}.ply") + "' -r 0.025";

    CliResult r = run_cli(tmp, "reconstruct " + in + out);
    INFO(r.err);
    REQUIRE(r.code == 0);
    CHECK(r.err.empty());
    CHECK(frames_printed(r.out) == std::vector<std::string>{"1", "2", "0007", "10"});
    CHECK(r.out.find("frame 0007 [3/4]: 216 particles") != std::string::npos);
    CHECK(r.out.find("4 frames: 4 ok, 0 failed, 0 skipped") != std::string::npos);
    for (const char* n : {"1", "2", "0007", "10"}) CHECK(closed_mesh(tmp.file(std::string("m_") + n + ".ply")));
    CHECK_FALSE(std::filesystem::exists(tmp.file("m_7.ply")));
    CHECK_FALSE(std::filesystem::exists(tmp.file("m_x3.ply")));

    // The range is inclusive and in frame numbers, whatever the padding.
    for (const char* n : {"1", "2", "0007", "10"}) std::filesystem::remove(tmp.file(std::string("m_") + n + ".ply"));
    r = run_cli(tmp, "reconstruct " + in + out + " --start 2 --end 7");
    REQUIRE(r.code == 0);
    CHECK(frames_printed(r.out) == std::vector<std::string>{"2", "0007"});
    CHECK(r.out.find("2 frames: 2 ok, 0 failed, 0 skipped") != std::string::npos);
    CHECK(std::filesystem::exists(tmp.file("m_2.ply")));
    CHECK_FALSE(std::filesystem::exists(tmp.file("m_1.ply")));
    CHECK_FALSE(std::filesystem::exists(tmp.file("m_10.ply")));
    r = run_cli(tmp, "reconstruct " + in + out + " --start 8");
    REQUIRE(r.code == 0);
    CHECK(frames_printed(r.out) == std::vector<std::string>{"10"});
    // Every "{}" of an output name takes the number (the second stayed "{}" before).
    r = run_cli(tmp, "reconstruct " + in + " -o '" + tmp.file("m_{}_of_{}.ply") + "' -r 0.025 --start 8");
    REQUIRE(r.code == 0);
    CHECK(closed_mesh(tmp.file("m_10_of_10.ply")));
}

TEST_CASE("CLI sequences: --skip-existing resumes, a failing frame is reported and the run goes on", "[cli][sequence]") {
    TempDir tmp;
    for (int f = 0; f < 6; ++f) trilevel::write_particles(tmp.file("f_" + std::to_string(f) + ".xyz"), small_block(0.01f * f));
    const std::string args = "reconstruct '" + tmp.file("f_{}.xyz") + "' -o '" + tmp.file("m_{}.ply") + "' -r 0.025";

    // An interrupted run left frames 0 and 2 (outputs are written by rename: they are complete).
    { std::ofstream(tmp.file("m_0.ply")) << "kept"; }
    { std::ofstream(tmp.file("m_2.ply")) << "kept"; }
    // Frame 3 is corrupt: 13 bytes are not whole float triplets.
    { std::ofstream(tmp.file("f_3.xyz"), std::ios::binary) << "not particles"; }
    CliResult r = run_cli(tmp, args + " --skip-existing");
    INFO(r.out << r.err);
    CHECK(r.code == 1);
    CHECK(frames_printed(r.out) == std::vector<std::string>{"1", "4", "5"});
    CHECK(r.out.find("6 frames: 3 ok, 1 failed (frame 3: ") != std::string::npos);
    CHECK(r.out.find("), 2 skipped") != std::string::npos);
    // One line for the failing frame, naming the file and the problem, and one at the end.
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 2);
    CHECK(r.err.rfind("trilevel: error: frame 3: ", 0) == 0);
    CHECK(r.err.find("f_3.xyz") != std::string::npos);
    CHECK(r.err.find("trilevel: error: 1 of 6 frames failed\n") != std::string::npos);
    CHECK(slurp(tmp.file("m_0.ply")) == "kept");
    CHECK(slurp(tmp.file("m_2.ply")) == "kept");
    CHECK_FALSE(std::filesystem::exists(tmp.file("m_3.ply")));
    for (int f : {1, 4, 5}) CHECK(closed_mesh(tmp.file("m_" + std::to_string(f) + ".ply")));

    // Once frame 3 is repaired, resuming processes it alone; --quiet prints nothing then.
    trilevel::write_particles(tmp.file("f_3.xyz"), small_block(0.03f));
    r = run_cli(tmp, args + " --skip-existing -q");
    CHECK(r.code == 0);
    CHECK(r.out.empty());
    CHECK(r.err.empty());
    CHECK(closed_mesh(tmp.file("m_3.ply")));
    // With statistics asked for, a frame whose statistics are missing is not complete.
    r = run_cli(tmp, args + " --skip-existing --stats '" + tmp.file("s_{}.json") + "' --start 4");
    CHECK(r.code == 0);
    CHECK(r.out.find("2 frames: 2 ok, 0 failed, 0 skipped") != std::string::npos);
    CHECK(std::filesystem::exists(tmp.file("s_5.json")));
}

TEST_CASE("CLI sequences: option errors are one line and write nothing", "[cli][sequence]") {
    TempDir tmp;
    trilevel::write_particles(tmp.file("f_1.xyz"), small_block(0));
    trilevel::write_particles(tmp.file("f_2.xyz"), small_block(0));
    const std::string seq = "reconstruct '" + tmp.file("f_{}.xyz") + "' -o '" + tmp.file("m_{}.ply") + "' -r 0.025 ";
    const std::string one = "reconstruct '" + tmp.file("f_1.xyz") + "' -o '" + tmp.file("m.ply") + "' -r 0.025 ";
    struct Case {
        std::string args, message;
        int code = 2;  // usage errors; 1 for what is wrong with the files
    };
    const Case cases[] = {
        {one + "--start 1", "need a frame sequence"},
        {one + "--skip-existing", "need a frame sequence"},
        {seq + "--start 2 --end 1", "--start 2 is after --end 1"},
        {seq + "--start -1", "--start must be a frame number"},
        {seq + "--end 1.5", "--end must be a frame number"},
        {seq + "--start 3", "no frame in [3, last]; the files hold frames 1 to 2", 1},
        {seq + "--level-hysteresis 1", "--level-hysteresis must lie in [0, 1)"},
        {"generate falling-drop --radius 0.025 --frames 3 -o '" + tmp.file("g.xyz") + "'", "-o must contain '{}'"},
        {"generate falling-drop --radius 0.025 --frames 0 -o '" + tmp.file("g_{}.xyz") + "'", "--frames must be >= 1"},
    };
    for (const auto& [args, message, code] : cases) {
        INFO("trilevel " << args);
        const CliResult r = run_cli(tmp, args);
        INFO(r.err);
        CHECK(r.code == code);
        CHECK(r.err.rfind("trilevel: error: ", 0) == 0);
        CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
        CHECK(r.err.find(message) != std::string::npos);
    }
    CHECK_FALSE(std::filesystem::exists(tmp.file("m_1.ply")));
    CHECK_FALSE(std::filesystem::exists(tmp.file("m.ply")));
    CHECK_FALSE(std::filesystem::exists(tmp.file("g_0000.xyz")));
}

TEST_CASE("CLI sequences: a generated 200-frame sequence reconstructs with one command, resumably", "[cli][sequence][slow]") {
    TempDir tmp;
    const std::string frames = tmp.file("drop_{}.xyz"), meshes = tmp.file("mesh_{}.ply"), stats = tmp.file("stats_{}.json");
    CliResult r = run_cli(tmp, "generate falling-drop --radius 0.025 --seed 5 --frames 200 -o '" + frames + "'");
    REQUIRE(r.code == 0);
    CHECK(r.out.find("11672 particles -> " + tmp.file("drop_0199.xyz")) != std::string::npos);
    REQUIRE(trilevel::read_particles(tmp.file("drop_0123.xyz")).positions ==
            trilevel::generate_scene("falling-drop", 0.025f, 5, 123).positions);

    const std::string cmd = "reconstruct '" + frames + "' -r 0.025 -o '" + meshes + "' --stats '" + stats + "'";
    r = run_cli(tmp, cmd);
    INFO(r.err);
    REQUIRE(r.code == 0);
    CHECK(r.err.empty());
    CHECK(r.out.find("frame 0199 [200/200]: 11672 particles") != std::string::npos);
    CHECK(r.out.find("200 frames: 200 ok, 0 failed, 0 skipped") != std::string::npos);
    CHECK(r.out.find("level changes between consecutive frames: ") != std::string::npos);
    CHECK(r.out.find("frames/s, ETA ") != std::string::npos);
    for (int f : {0, 57, 199}) CHECK(closed_mesh(tmp.file("mesh_" + padded(f) + ".ply")));
    // The first frame has no previous one; every later one reports its level changes.
    CHECK(slurp(tmp.file("stats_0000.json")).find("\"level_flips\"") == std::string::npos);
    CHECK(slurp(tmp.file("stats_0001.json")).find("\"level_flips\"") != std::string::npos);

    // Resume after losing three frames: only those are made again.
    for (int f : {3, 100, 150}) std::filesystem::remove(tmp.file("mesh_" + padded(f) + ".ply"));
    r = run_cli(tmp, cmd + " --skip-existing");
    REQUIRE(r.code == 0);
    CHECK(frames_printed(r.out) == std::vector<std::string>{"0003", "0100", "0150"});
    CHECK(r.out.find("200 frames: 3 ok, 0 failed, 197 skipped") != std::string::npos);
    for (int f : {3, 100, 150}) CHECK(closed_mesh(tmp.file("mesh_" + padded(f) + ".ply")));
}

TEST_CASE("CLI sequences: on a terminal, a progress bar with frame count, rate and ETA", "[cli][sequence]") {
    if (std::system("script -qec true /dev/null >/dev/null 2>&1") != 0) {
        WARN("SKIPPED: no util-linux `script` to run the CLI on a pseudo-terminal");
        return;
    }
    TempDir tmp;
    for (int f = 0; f < 3; ++f) trilevel::write_particles(tmp.file("f_" + std::to_string(f) + ".xyz"), small_block(0.01f * f));
    // `script` gives the CLI a pseudo-terminal for stdout and stderr; its transcript is both.
    const std::string inner = std::string("'") + TRILEVEL_CLI + "' reconstruct '" + tmp.file("f_{}.xyz") + "' -o '" +
                              tmp.file("m_{}.ply") + "' -r 0.025";
    const std::string cmd = "script -qec \"" + inner + "\" /dev/null >'" + tmp.file("tty.txt") + "' 2>&1";
    REQUIRE(std::system(cmd.c_str()) == 0);
    const std::string tty = slurp(tmp.file("tty.txt"));
    INFO(tty);
    CHECK(tty.find("\r[------------------------] 0/3 frames, ETA ? (frame 0)") != std::string::npos);
    CHECK(tty.find("\r[########################] 3/3 frames, ") != std::string::npos);
    CHECK(tty.find(" frames/s, ETA 0:00 (frame 2)") != std::string::npos);
    CHECK(tty.find("frame 0 [") == std::string::npos);  // no plain lines on a terminal
    CHECK(tty.find("3 frames: 3 ok, 0 failed, 0 skipped") != std::string::npos);
}
