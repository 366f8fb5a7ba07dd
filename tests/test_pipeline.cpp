// Pipelined frame sequences: trilevel::FramePipeline gives the meshes, statistics and level
// history of Reconstructor::reconstruct called frame by frame, in push order, with failed frames in
// their place; the CLI's pipelined sequence mode writes the bytes of its one-frame-at-a-time mode
// (TRILEVEL_PIPELINE=0), and a bad frame in the middle is one line, with no output of its own.
#include <filesystem>
#include <mutex>

#include "cli_test_support.hpp"
#include "trilevel/io.hpp"
#include "trilevel/pipeline.hpp"

using trilevel::test::CliResult;
using trilevel::test::run_cli;
using trilevel::test::same_mesh;
using trilevel::test::ScopedEnv;
using trilevel::test::slurp;
using trilevel::test::TempDir;

namespace {

trilevel::Params sequence_params() {
    trilevel::Params p;
    p.particle_radius = 0.025f;
    p.level_hysteresis = 0.2f;  // the history matters: each frame depends on the one before
    return p;
}

std::vector<float> falling_drop(int frame) {
    return trilevel::generate_scene("falling-drop", 0.025f, 1, frame).positions;
}

/// The stages a frame's statistics time, in their order.
std::vector<std::string> stage_names(const trilevel::Stats& s) {
    std::vector<std::string> names;
    for (const auto& [name, ms] : s.time_ms) names.push_back(name);
    return names;
}

/// What a pipelined frame shares with the same frame meshed by reconstruct(): the mesh, its
/// counts, the level history's figures and the stages timed, in order.
void check_same_frame(const trilevel::PipelineFrame& got, const trilevel::Mesh& mesh, const trilevel::Stats& b) {
    REQUIRE_FALSE(got.error);
    CHECK(same_mesh(got.mesh, mesh));
    const trilevel::Stats& a = got.stats;
    CHECK(a.closed);
    CHECK(a.particles == b.particles);
    CHECK(a.triangles == b.triangles);
    CHECK(a.fine_points == b.fine_points);
    CHECK(a.surface_cells == b.surface_cells);
    CHECK(a.crack_vertices_collapsed == b.crack_vertices_collapsed);
    CHECK(a.level_history == b.level_history);
    CHECK(a.level_flips == b.level_flips);
    CHECK(a.level_held == b.level_held);
    CHECK(stage_names(a) == stage_names(b));
}

std::size_t files_in(const std::string& dir) {
    std::size_t n = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) n += e.is_regular_file();
    return n;
}

}  // namespace

TEST_CASE("FramePipeline: the meshes, stats and history of frame-by-frame calls, a failed frame in its place", "[pipeline]") {
    const trilevel::Params p = sequence_params();
    constexpr int kFrames = 6, kFailed = 3;  // frame 3 fails to be produced (pushed as an error)
    // Reference: one Reconstructor called frame by frame, skipping frame 3.
    std::vector<trilevel::Mesh> expected(kFrames);
    std::vector<trilevel::Stats> expected_stats(kFrames);
    {
        trilevel::Reconstructor rec;
        for (int f = 0; f < kFrames; ++f)
            if (f != kFailed) expected[f] = rec.reconstruct(falling_drop(f), p, &expected_stats[f]);
    }
    trilevel::Reconstructor rec;
    std::vector<trilevel::PipelineFrame> got;
    std::mutex m;
    {
        trilevel::FramePipeline pipe(rec, p, [&](trilevel::PipelineFrame& f) {
            std::lock_guard lock(m);
            got.push_back(std::move(f));
        });
        for (int f = 0; f < kFrames; ++f) {
            if (f == kFailed) pipe.push_failed(std::make_exception_ptr(trilevel::Error("frame 3: unreadable")));
            else pipe.push(falling_drop(f));
        }
        pipe.finish();
    }
    REQUIRE(got.size() == kFrames);
    for (int f = 0; f < kFrames; ++f) {
        INFO("frame " << f);
        CHECK(got[f].index == std::uint64_t(f));
        if (f == kFailed) {
            REQUIRE(got[f].error);
            CHECK(got[f].mesh.triangle_count() == 0);
            CHECK_THROWS_WITH(std::rethrow_exception(got[f].error), "frame 3: unreadable");
            continue;
        }
        REQUIRE_FALSE(got[f].error);
        CHECK(same_mesh(got[f].mesh, expected[f]));
        CHECK(trilevel::is_closed_and_oriented(got[f].mesh));
        CHECK(got[f].stats.level_history == (f > 0));
        CHECK(got[f].stats.level_flips == expected_stats[f].level_flips);
        CHECK(got[f].stats.level_held == expected_stats[f].level_held);
        CHECK(got[f].stats.level_cells_compared == expected_stats[f].level_cells_compared);
    }
    CHECK(expected_stats[4].level_history);  // frame 4 was compared with frame 2 in both
    // The Reconstructor carries on after the pipeline: frame 6 continues the same history.
    trilevel::Stats s6;
    const trilevel::Mesh m6 = rec.reconstruct(falling_drop(6), p, &s6);
    CHECK(s6.level_history);
}

TEST_CASE("FramePipeline: post-processing beside the next frame's meshing gives the frame-by-frame meshes and stats",
          "[pipeline]") {
    // Smoothing, sliver cleanup and normals make the pipeline run each frame's post-processing on
    // its finisher thread while the worker meshes the next frame; a particle box and an attribute
    // take the tail's own copies of the positions and attributes; frame 2 fails in the worker and
    // passes the finisher in its place.
    const ScopedEnv finisher("TRILEVEL_PIPELINE_FINISHER", "1");  // on for a CPU device too
    trilevel::Params p = sequence_params();
    p.smooth = true;
    p.sliver_cleanup = true;
    p.normals = trilevel::NormalMode::Area;
    constexpr int kFrames = 5, kBad = 2;
    auto frame = [&](int f) {
        std::vector<float> xyz = falling_drop(f);
        trilevel::ParticleAttribute height{"height", 1, {}};
        for (std::size_t i = 0; i < xyz.size(); i += 3) height.values.push_back(xyz[i + 2]);
        if (f == kBad) height.values.pop_back();  // one value short: rejected before the box is applied
        return std::pair{xyz, std::vector<trilevel::ParticleAttribute>{height}};
    };
    {  // a box that leaves the highest particles of frame 0 out
        const std::vector<float> xyz = falling_drop(0);
        trilevel::Box box{{-1e3f, -1e3f, -1e3f}, {1e3f, 1e3f, 0.0f}};
        for (std::size_t i = 0; i < xyz.size(); i += 3) box.max[2] = std::max(box.max[2], xyz[i + 2]);
        box.max[2] -= 0.1f;
        p.particle_box = box;
    }
    std::vector<trilevel::Mesh> expected(kFrames);
    std::vector<trilevel::Stats> expected_stats(kFrames);
    {
        trilevel::Reconstructor rec;
        for (int f = 0; f < kFrames; ++f) {
            auto [xyz, attributes] = frame(f);
            if (f != kBad) expected[f] = rec.reconstruct(std::move(xyz), p, &expected_stats[f], attributes);
        }
    }
    REQUIRE(expected_stats[0].particles_outside_box > 0);
    REQUIRE(expected_stats[0].time_ms.size() > 2);
    trilevel::Reconstructor rec;
    std::vector<trilevel::PipelineFrame> got;
    {
        trilevel::FramePipeline pipe(rec, p, [&](trilevel::PipelineFrame& f) { got.push_back(std::move(f)); });
        for (int f = 0; f < kFrames; ++f) {
            auto [xyz, attributes] = frame(f);
            pipe.push(std::move(xyz), std::move(attributes));
        }
        pipe.finish();
    }
    REQUIRE(got.size() == kFrames);
    for (int f = 0; f < kFrames; ++f) {
        INFO("frame " << f);
        CHECK(got[f].index == std::uint64_t(f));
        if (f == kBad) {
            REQUIRE(got[f].error);
            CHECK_THROWS_WITH(std::rethrow_exception(got[f].error), Catch::Contains("height"));
            continue;
        }
        check_same_frame(got[f], expected[f], expected_stats[f]);
        REQUIRE(got[f].mesh.attributes.size() == 1);
        REQUIRE_FALSE(got[f].mesh.normals.empty());
        const trilevel::Stats &a = got[f].stats, &b = expected_stats[f];
        CHECK(a.particles_outside_box == b.particles_outside_box);
        CHECK(a.sliver_edges_collapsed == b.sliver_edges_collapsed);
        CHECK(a.smoothing_reverted_moves == b.smoothing_reverted_moves);
        CHECK(stage_names(a).back() == "total");
    }
}

TEST_CASE("FramePipeline: triangulation beside the next frame's device stages gives the frame-by-frame meshes and stats",
          "[pipeline]") {
    // With the finisher on (TRILEVEL_PIPELINE_FINISHER=1 for a CPU device), frame k's triangulation
    // and crack closing run on the finisher from a host copy of its fine-point table while the
    // worker runs frame k+1's device stages, whose level history must already hold frame k's levels.
    // Frame 2 is scaled far below the float kernels' range (triangulated in the worker, then scaled
    // back) and frame 4 fails in the worker.
    const ScopedEnv finisher("TRILEVEL_PIPELINE_FINISHER", "1");
    const trilevel::Params p = sequence_params();
    constexpr int kFrames = 6, kScaled = 2, kBad = 4;
    constexpr float kScale = 1.0f / 1048576.0f;  // 2^-20: exact
    auto frame = [&](int f) {
        std::vector<float> xyz = falling_drop(f);
        if (f == kBad) xyz[3 * 5] = std::numeric_limits<float>::infinity();
        return xyz;
    };
    auto params_of = [&](int f) {
        trilevel::Params q = p;
        if (f == kScaled) q.particle_radius *= kScale;
        return q;
    };
    auto scaled = [&](std::vector<float> xyz, int f) {
        if (f == kScaled)
            for (float& v : xyz) v *= kScale;
        return xyz;
    };
    std::vector<trilevel::Mesh> expected(kFrames);
    std::vector<trilevel::Stats> expected_stats(kFrames);
    {
        trilevel::Reconstructor rec;
        for (int f = 0; f < kFrames; ++f)
            if (f != kBad) expected[f] = rec.reconstruct(scaled(frame(f), f), params_of(f), &expected_stats[f]);
    }
    REQUIRE(expected_stats[1].crack_vertices_collapsed > 0);
    // A pipeline takes one Params for every frame: the scaled frame goes through a pipeline of its own
    // between the others, as a caller would, with the Reconstructor's history carried through.
    trilevel::Reconstructor rec;
    std::vector<trilevel::PipelineFrame> got;
    auto run = [&](int first, int last, const trilevel::Params& q) {
        trilevel::FramePipeline pipe(rec, q, [&](trilevel::PipelineFrame& f) { got.push_back(std::move(f)); });
        for (int f = first; f <= last; ++f) pipe.push(scaled(frame(f), f));
        pipe.finish();
    };
    run(0, 1, p);
    run(2, 2, params_of(2));
    run(3, kFrames - 1, p);
    REQUIRE(got.size() == kFrames);
    for (int f = 0; f < kFrames; ++f) {
        INFO("frame " << f);
        if (f == kBad) {
            REQUIRE(got[f].error);
            CHECK_THROWS_WITH(std::rethrow_exception(got[f].error), Catch::Contains("non-finite"));
            continue;
        }
        check_same_frame(got[f], expected[f], expected_stats[f]);
        const trilevel::Stats &a = got[f].stats, &b = expected_stats[f];
        CHECK(a.fine_points_level3 == b.fine_points_level3);  // counted on the finisher
        CHECK(a.surface_cells_level3 == b.surface_cells_level3);
        CHECK(a.device_memory_bytes == b.device_memory_bytes);  // recorded by the worker
        CHECK(a.kernel_ms.size() == b.kernel_ms.size());
    }
}

TEST_CASE("FramePipeline: parameters every frame would refuse are an error at construction", "[pipeline]") {
    trilevel::Reconstructor rec;
    trilevel::Params p = sequence_params();
    p.kernel_radius = 100.0f;
    int frames = 0;
    CHECK_THROWS_WITH(trilevel::FramePipeline(rec, p, [&](trilevel::PipelineFrame&) { ++frames; }),
                      "kernel radius must lie in [1, 16] particle radii, got 100.000000");
    p = sequence_params();
    p.mode = trilevel::Mode::Uniform;
    p.cell = 3.0f;
    CHECK_THROWS_WITH(trilevel::FramePipeline(rec, p, [&](trilevel::PipelineFrame&) { ++frames; }),
                      Catch::Contains("cell size 3 must be 4/n radii"));
    CHECK(frames == 0);
    trilevel::FramePipeline ok(rec, sequence_params(), [&](trilevel::PipelineFrame& f) { frames += f.error ? 0 : 1; });
    ok.push(falling_drop(0));
    ok.finish();
    CHECK(frames == 1);  // the Reconstructor is as good as before
}

TEST_CASE("FramePipeline: a frame reconstruct rejects fails alone, and a sink that throws stops the pipeline", "[pipeline]") {
    trilevel::Reconstructor rec;
    const trilevel::Params p = sequence_params();
    std::vector<std::string> seen;
    {
        trilevel::FramePipeline pipe(rec, p, [&](trilevel::PipelineFrame& f) {
            if (!f.error) seen.push_back(std::to_string(f.mesh.triangle_count() > 0));
            else {
                try {
                    std::rethrow_exception(f.error);
                } catch (const trilevel::Error& e) {
                    seen.push_back(e.what());
                }
            }
        });
        pipe.push(falling_drop(0));
        std::vector<float> bad = falling_drop(1);
        bad[3 * 17 + 1] = std::numeric_limits<float>::quiet_NaN();
        pipe.push(std::move(bad));
        pipe.push(falling_drop(2));
        pipe.finish();
    }
    CHECK(seen == std::vector<std::string>{"1", "particle 17 has a non-finite coordinate", "1"});

    trilevel::FramePipeline pipe(rec, p, [&](trilevel::PipelineFrame& f) {
        if (f.index == 0) throw std::runtime_error("disk full");
    });
    pipe.push(falling_drop(3));
    // The sink's error comes back from a later push or from finish.
    CHECK_THROWS_WITH(
        [&] {
            for (int f = 4; f < 8; ++f) pipe.push(falling_drop(f));
            pipe.finish();
        }(),
        "disk full");
}

TEST_CASE("FramePipeline: a memory limit counts the mesh being written and the next frame read ahead", "[pipeline]") {
    const trilevel::Params base = sequence_params();
    trilevel::Stats one;
    trilevel::Mesh first;
    {
        trilevel::Reconstructor rec;
        first = rec.reconstruct(falling_drop(0), base, &one);
    }
    const std::uint64_t need = trilevel::test::frame_memory_need(one);
    const std::uint64_t input = falling_drop(0).size() * sizeof(float);
    const std::uint64_t mesh = first.positions.size() * 4 + first.triangles.size() * 4 + first.vertex_level.size() +
                               first.triangle_kind.size();
    // Frame 0 runs under limit - input (no mesh held yet); frame 1 under limit - input - mesh 0.
    trilevel::Params p = base;
    p.memory_limit_bytes = need + input + mesh / 2;  // enough for frame 0, not for frame 1 beside mesh 0
    trilevel::Reconstructor rec;
    std::vector<std::string> outcome;
    {
        trilevel::FramePipeline pipe(rec, p, [&](trilevel::PipelineFrame& f) {
            if (!f.error) return outcome.push_back("ok");
            try {
                std::rethrow_exception(f.error);
            } catch (const trilevel::Error& e) {
                outcome.push_back(e.what());
            }
        });
        pipe.push(falling_drop(0));
        pipe.push(falling_drop(0));
        pipe.finish();
    }
    REQUIRE(outcome.size() == 2);
    CHECK(outcome[0] == "ok");
    CHECK(outcome[1].find("over the budget") != std::string::npos);

    // A limit below what is in flight fails with a message naming the pipeline.
    p.memory_limit_bytes = input;
    trilevel::FramePipeline pipe(rec, p, [&](trilevel::PipelineFrame& f) {
        REQUIRE(f.error);
        CHECK_THROWS_WITH(std::rethrow_exception(f.error),
                          Catch::Contains("leaves nothing for this frame") && Catch::Contains("next frame read ahead"));
    });
    pipe.push(falling_drop(0));
    pipe.finish();
}

TEST_CASE("CLI sequences: pipelined output is the bytes of one frame at a time, and a bad frame in the middle fails alone",
          "[cli][sequence][pipeline]") {
    TempDir tmp;
    for (int f = 0; f < 6; ++f)
        trilevel::write_particles(tmp.file("in_" + std::to_string(f) + ".ply"), trilevel::generate_scene("falling-drop", 0.025f, 1, f));
    std::filesystem::create_directories(tmp.file("pipe"));
    std::filesystem::create_directories(tmp.file("one"));
    const std::string in = "reconstruct '" + tmp.file("in_{}.ply") + "' -r 0.025 --normals area ";
    const CliResult pipe = run_cli(tmp, in + "-o '" + tmp.file("pipe/m_{}.ply") + "' --stats '" + tmp.file("pipe/s_{}.json") + "'");
    INFO(pipe.err);
    REQUIRE(pipe.code == 0);
    CliResult one;
    {
        ScopedEnv off("TRILEVEL_PIPELINE", "0");
        one = run_cli(tmp, in + "-o '" + tmp.file("one/m_{}.ply") + "'");
    }
    REQUIRE(one.code == 0);
    for (int f = 0; f < 6; ++f) {
        INFO("frame " << f);
        const std::string a = slurp(tmp.file("pipe/m_" + std::to_string(f) + ".ply"));
        CHECK(!a.empty());
        CHECK(a == slurp(tmp.file("one/m_" + std::to_string(f) + ".ply")));
        CHECK(slurp(tmp.file("pipe/s_" + std::to_string(f) + ".json")).find("\"triangles\"") != std::string::npos);
    }
    // The same progress lines, in frame order, with the same level changes (times aside).
    auto level_lines = [](const std::string& out) {
        std::vector<std::string> v;
        std::istringstream s(out);
        for (std::string line; std::getline(s, line);)
            if (line.rfind("frame ", 0) == 0) v.push_back(line.substr(0, line.find(" triangles")) + line.substr(line.find(" ms") + 3, line.find(";") - line.find(" ms") - 3));
            else if (line.rfind("level changes", 0) == 0) v.push_back(line);
        return v;
    };
    CHECK(level_lines(pipe.out) == level_lines(one.out));
    CHECK(level_lines(pipe.out).size() == 7);

    // Frame 3 is not a particle file: its error is one line, frames 0-2 and 4-5 are written, and
    // no file (not even a temporary one) is left for frame 3.
    { std::ofstream(tmp.file("in_3.ply"), std::ios::binary) << "ply\nformat binary_little_endian 1.0\nelement vertex 99\n"; }
    std::filesystem::create_directories(tmp.file("bad"));
    const CliResult bad = run_cli(tmp, in + "-o '" + tmp.file("bad/m_{}.ply") + "'");
    CHECK(bad.code == 1);
    std::vector<std::string> err_lines;
    {
        std::istringstream s(bad.err);
        for (std::string line; std::getline(s, line);) err_lines.push_back(line);
    }
    REQUIRE(err_lines.size() == 2);
    CHECK(err_lines[0].rfind("trilevel: error: frame 3: " + tmp.file("in_3.ply") + ": ", 0) == 0);
    CHECK(err_lines[1] == "trilevel: error: 1 of 6 frames failed");
    CHECK(bad.out.find("6 frames: 5 ok, 1 failed (frame 3: ") != std::string::npos);
    CHECK(files_in(tmp.file("bad")) == 5);
    CHECK_FALSE(std::filesystem::exists(tmp.file("bad/m_3.ply")));
    // Frames after the bad one follow frame 2's history, as one frame at a time does.
    std::filesystem::create_directories(tmp.file("bad1"));
    {
        ScopedEnv off("TRILEVEL_PIPELINE", "0");
        const CliResult r = run_cli(tmp, in + "-o '" + tmp.file("bad1/m_{}.ply") + "'");
        CHECK(r.code == 1);
        CHECK(r.err == bad.err);
    }
    for (int f : {0, 1, 2, 4, 5})
        CHECK(slurp(tmp.file("bad/m_" + std::to_string(f) + ".ply")) == slurp(tmp.file("bad1/m_" + std::to_string(f) + ".ply")));
}
