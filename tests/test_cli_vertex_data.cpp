// The CLI's --normals and --attribute options: what they write, and their errors.
#include <algorithm>
#include <cmath>
#include <fstream>

#include <glm/glm.hpp>

#include "cli_test_support.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"

using trilevel::test::CliResult;
using trilevel::test::TempDir;
using trilevel::test::run_cli;

namespace {

std::string quoted(const std::string& p) { return "'" + p + "'"; }

glm::dvec3 velocity(glm::dvec3 x) { return glm::dvec3(x.y, -x.x, 0.5 * x.z); }  // a rotation: |M| = 1

/// A legacy ASCII VTK particle file with a `velocity` vector per particle.
void write_vtk_with_velocity(const std::string& path, const trilevel::ParticleSet& s) {
    std::ofstream out(path);
    out << "# vtk DataFile Version 3.0\nparticles\nASCII\nDATASET POLYDATA\nPOINTS " << s.size() << " float\n";
    out.precision(9);
    for (std::size_t i = 0; i < s.size(); ++i)
        out << s.positions[3 * i] << ' ' << s.positions[3 * i + 1] << ' ' << s.positions[3 * i + 2] << '\n';
    out << "POINT_DATA " << s.size() << "\nVECTORS velocity float\n";
    for (std::size_t i = 0; i < s.size(); ++i) {
        const glm::dvec3 u = velocity(glm::dvec3(s.positions[3 * i], s.positions[3 * i + 1], s.positions[3 * i + 2]));
        out << float(u.x) << ' ' << float(u.y) << ' ' << float(u.z) << '\n';
    }
}

}  // namespace

TEST_CASE("CLI --normals writes unit normals to PLY, VTK and OBJ", "[cli][normals]") {
    TempDir tmp;
    trilevel::write_particles(tmp.file("s.ply"), trilevel::generate_scene("sphere", 0.025f, 1));
    for (const std::string& opt : {std::string("--normals"), std::string("--normals gradient"), std::string("--normals area")})
        for (const std::string ext : {"ply", "vtk", "obj"}) {
            const std::string out = tmp.file("m." + ext);
            INFO(opt << " ." << ext);
            const CliResult r = run_cli(tmp, "reconstruct " + quoted(tmp.file("s.ply")) + " -r 0.025 " + opt + " -o " + quoted(out));
            INFO(r.err);
            REQUIRE(r.code == 0);
            const trilevel::Mesh m = trilevel::read_mesh(out);
            REQUIRE(m.normals.size() == m.positions.size());
            for (std::size_t v = 0; v < m.vertex_count(); ++v)
                REQUIRE(std::hypot(m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2]) == Approx(1.0).margin(1e-6));
        }
    // Without the option there are none (and the file is the same as before the option existed).
    REQUIRE(run_cli(tmp, "reconstruct " + quoted(tmp.file("s.ply")) + " -r 0.025 -o " + quoted(tmp.file("p.ply"))).code == 0);
    REQUIRE(trilevel::read_mesh(tmp.file("p.ply")).normals.empty());
}

TEST_CASE("CLI --normals and --attribute errors are one clear line and leave no output", "[cli][errors]") {
    TempDir tmp;
    trilevel::write_particles(tmp.file("s.ply"), trilevel::generate_scene("sphere", 0.025f, 1));
    const std::string out = tmp.file("m.ply");
    CliResult r = run_cli(tmp, "reconstruct " + quoted(tmp.file("s.ply")) + " -r 0.025 --normals sideways -o " + quoted(out));
    CHECK(r.code == 2);
    CHECK(r.err == "trilevel: error: --normals must be gradient or area (or given alone), got 'sideways'\n");
    r = run_cli(tmp, "reconstruct " + quoted(tmp.file("s.ply")) + " -r 0.025 --attribute velocity -o " + quoted(out));
    CHECK(r.code == 1);
    CHECK(r.err.rfind("trilevel: error: ", 0) == 0);
    CHECK(r.err.find("s.ply") != std::string::npos);
    CHECK(r.err.find("'velocity'") != std::string::npos);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    CHECK(!std::filesystem::exists(out));
}

TEST_CASE("CLI --attribute velocity interpolates a VTK file's velocities onto PLY and VTK vertices", "[cli][attributes]") {
    TempDir tmp;
    const float r = 0.025f;
    const auto s = trilevel::generate_scene("sphere", r, 1);
    write_vtk_with_velocity(tmp.file("v.vtk"), s);
    for (const std::string ext : {"ply", "vtk"}) {
        const std::string out = tmp.file("m." + ext);
        const CliResult run = run_cli(tmp, "reconstruct " + quoted(tmp.file("v.vtk")) + " -r 0.025 --normals --attribute velocity -o " + quoted(out));
        INFO(ext << ": " << run.err);
        REQUIRE(run.code == 0);
        const trilevel::Mesh m = trilevel::read_mesh(out);
        REQUIRE(m.normals.size() == m.positions.size());
        REQUIRE(m.attributes.size() == 1);
        REQUIRE(m.attributes[0].name == "velocity");
        REQUIRE(m.attributes[0].components == 3);
        // The interpolated velocity is the rotation's value at the kernel-weighted mean position,
        // less than R = 4r from the vertex.
        for (std::size_t v = 0; v < m.vertex_count(); ++v) {
            const glm::dvec3 x(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]);
            const glm::dvec3 u(m.attributes[0].values[3 * v], m.attributes[0].values[3 * v + 1], m.attributes[0].values[3 * v + 2]);
            REQUIRE(glm::length(u - velocity(x)) < 4 * r);
        }
    }
}
