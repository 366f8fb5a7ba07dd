// Prints the quality measures of a mesh file (host/mesh_quality.hpp) as one JSON object: against
// the exact surface of a generated analytic scene (ball, torus, rounded-box) when --body names one.
//
//   mesh_quality MESH --radius R [--particles N] [--body ball|torus|rounded-box]
//
// Reads what trilevel's read_mesh reads (PLY binary or ASCII, OBJ, VTK), splashsurf's PLY included.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <optional>
#include <string>

#include "mesh_quality.hpp"
#include "trilevel/io.hpp"

int main(int argc, char** argv) {
    std::string path, body_name;
    double r = 0;
    std::size_t particles = 0;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&]() -> std::string {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "mesh_quality: error: %s needs a value\n", a.c_str());
                std::exit(2);
            }
            return argv[++i];
        };
        if (a == "--radius") r = std::stod(value());
        else if (a == "--particles") particles = std::stoull(value());
        else if (a == "--body") body_name = value();
        else if (path.empty()) path = a;
        else {
            std::fprintf(stderr, "mesh_quality: error: unexpected argument '%s'\n", a.c_str());
            return 2;
        }
    }
    if (path.empty() || !(r > 0)) {
        std::fprintf(stderr, "usage: mesh_quality MESH --radius R [--particles N] [--body ball|torus|rounded-box]\n");
        return 2;
    }
    try {
        const auto body = body_name.empty() ? std::nullopt : trilevel::analytic_body(body_name, r);
        if (!body_name.empty() && !body) throw trilevel::Error("unknown body '" + body_name + "'");
        const trilevel::Mesh mesh = trilevel::read_mesh(path);
        const trilevel::MeshQuality q = trilevel::mesh_quality(mesh, r, particles, body ? &*body : nullptr);
        std::string euler;
        for (std::size_t c = 0; c < q.euler.size() && c < 8; ++c) euler += (c ? "," : "") + std::to_string(q.euler[c]);
        auto number = [](double x, int digits) {  // JSON has no NaN: null where no body was given
            if (!std::isfinite(x)) return std::string("null");
            char buf[64];
            std::snprintf(buf, sizeof buf, "%.*f", digits, x);
            return std::string(buf);
        };
        std::printf("{\"mesh\": \"%s\", \"triangles\": %zu, \"vertices\": %zu, \"closed\": %s, \"components\": %zu, "
                    "\"euler_first\": [%s], \"normal_rms_deg\": %s, \"surface_rms_r\": %s, \"surface_offset_r\": %s, "
                    "\"sliver_share\": %.5f, \"min_angle_deg\": %.3f, \"volume\": %.9g, \"volume_ratio\": %.5f}\n",
                    path.c_str(), q.triangles, q.vertices, q.closed ? "true" : "false", q.components, euler.c_str(),
                    number(q.normal_rms_deg, 3).c_str(), number(q.surface_rms, 4).c_str(), number(q.surface_offset, 4).c_str(), q.sliver_share, q.min_angle_deg, q.volume,
                    q.volume_ratio);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "mesh_quality: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
