// The CLI's post-processing options: --particle-box, --remove-components-below, --clip-box. Bad
// values give one exact stderr line and exit 2 (usage) or 1 (nothing inside the particle box),
// and no output file.
#include <filesystem>

#include "cli_test_support.hpp"
#include "trilevel/io.hpp"

using trilevel::test::CliResult;
using trilevel::test::run_cli;
using trilevel::test::slurp;
using trilevel::test::TempDir;

namespace {

void require_exact_error(const TempDir& tmp, const std::string& args, const std::string& output, int code, const std::string& line) {
    INFO("trilevel " << args);
    const CliResult r = run_cli(tmp, args);
    CHECK(r.code == code);
    CHECK(r.err == "trilevel: error: " + line + "\n");
    CHECK(r.out.empty());
    CHECK_FALSE(std::filesystem::exists(output));
}

}  // namespace

TEST_CASE("CLI: bad --particle-box, --clip-box and --remove-components-below values", "[cli][clip]") {
    TempDir tmp;
    const std::string in = tmp.file("in.xyz"), out = tmp.file("out.ply");
    trilevel::write_particles(in, trilevel::generate_scene("block", 0.025f));
    const std::string base = "reconstruct '" + in + "' -o '" + out + "' -r 0.025 ";
    for (const std::string opt : {"--particle-box", "--clip-box"}) {
        for (const std::string bad : {"1,2,3", "0,0,0,1,1,1,1", "0,0,0,1,1,", "0,0,0,1,nan,1", "0,0,0,1,inf,1",
                                      "0,0,0,1,1e39,1", "a,b,c,d,e,f", "0;0;0;1;1;1", ""}) {
            require_exact_error(tmp, base + opt + " '" + bad + "'", out, 2,
                                opt + " must be six finite numbers X0,Y0,Z0,X1,Y1,Z1, got '" + bad + "'");
        }
        require_exact_error(tmp, base + opt + " 1,0,0,0,1,1", out, 2, opt + " is empty: X0 must be below X1, got '1,0,0,0,1,1'");
        require_exact_error(tmp, base + opt + " 0,1,0,1,1,1", out, 2, opt + " is empty: Y0 must be below Y1, got '0,1,0,1,1,1'");
        require_exact_error(tmp, base + opt + "=0,0,2,1,1,-1", out, 2, opt + " is empty: Z0 must be below Z1, got '0,0,2,1,1,-1'");
    }
    require_exact_error(tmp, base + "--remove-components-below abc", out, 2, "--remove-components-below must be a number, got 'abc'");
    require_exact_error(tmp, base + "--remove-components-below -1", out, 2,
                        "--remove-components-below must be finite and >= 0 (particle volumes), got '-1'");
    require_exact_error(tmp, base + "--remove-components-below nan", out, 2,
                        "--remove-components-below must be finite and >= 0 (particle volumes), got 'nan'");
    require_exact_error(tmp, base + "--remove-components-below inf", out, 2,
                        "--remove-components-below must be finite and >= 0 (particle volumes), got 'inf'");
    const auto n = trilevel::read_particles(in).size();
    require_exact_error(tmp, base + "--particle-box 5,5,5,6,6,6", out, 1,
                        "no particles inside the particle box [5, 6] x [5, 6] x [5, 6]: all " + std::to_string(n) + " lie outside");
}

TEST_CASE("CLI: clip box and component removal write a closed mesh in the box and report the counts", "[cli][clip]") {
    TempDir tmp;
    const std::string in = tmp.file("in.xyz"), out = tmp.file("out.ply"), stats = tmp.file("s.json");
    trilevel::write_particles(in, trilevel::generate_scene("pool-and-drop", 0.025f));
    const CliResult r = run_cli(tmp, "reconstruct '" + in + "' -o '" + out + "' -r 0.025 --clip-box=-0.1,0.2,0.3,2.4,1.7,2.6 "
                                     "--remove-components-below 50 --particle-box -1,-1,-1,2.8,3,3 --stats '" + stats + "'");
    INFO(r.err);
    REQUIRE(r.code == 0);
    CHECK(r.err.empty());
    CHECK(r.out.find("closed: yes\n") != std::string::npos);
    CHECK(r.out.find("components removed: ") != std::string::npos);
    CHECK(r.out.find("clip-box cap triangles: ") != std::string::npos);
    CHECK(r.out.find("particles outside --particle-box: ") != std::string::npos);
    const trilevel::Mesh m = trilevel::read_mesh(out);
    REQUIRE(m.triangle_count() > 0);
    CHECK(trilevel::is_closed_and_oriented(m));
    const float lo[3] = {-0.1f, 0.2f, 0.3f}, hi[3] = {2.4f, 1.7f, 2.6f};
    for (std::size_t v = 0; v < m.vertex_count(); ++v)
        for (int k = 0; k < 3; ++k) {
            REQUIRE(m.positions[3 * v + k] >= lo[k] - 2.5e-6f);
            REQUIRE(m.positions[3 * v + k] <= hi[k] + 2.5e-6f);
        }
    const std::string json = slurp(stats);
    for (const char* key : {"\"components_removed\": ", "\"clip_cap_triangles\": ", "\"particles_outside_box\": ",
                            "\"remove_components_below\": 50.0", "\"clip_box\": {", "\"particle_box\": {"})
        CHECK(json.find(key) != std::string::npos);
    // a box without fluid: an empty mesh and a warning, exit 0
    const CliResult e = run_cli(tmp, "reconstruct '" + in + "' -o '" + tmp.file("e.ply") + "' -r 0.025 -q --clip-box 7,7,7,8,8,8");
    CHECK(e.code == 0);
    CHECK(e.err == "warning: " + in + ": --clip-box holds no part of the surface, the mesh is empty\n");
    CHECK(trilevel::read_mesh(tmp.file("e.ply")).triangle_count() == 0);
}
