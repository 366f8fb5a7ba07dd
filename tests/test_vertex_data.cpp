// Per-vertex normals and interpolated particle attributes (host/vertex_data.hpp): directions on
// shapes with known normals, exactness of the interpolation, determinism, errors, and round trips
// through the writers and readers.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>

#include <glm/glm.hpp>
#include <tbb/global_control.h>

#include "reference/reference_stages.hpp"
#include "test_support.hpp"
#include "trilevel/io.hpp"
#include "trilevel/trilevel.hpp"
#include "vertex_data.hpp"

using namespace trilevel;
using trilevel::test::TempDir;

using trilevel::test::same_mesh;

using trilevel::test::same_bits;

namespace {

Reconstructor& reconstructor() {
    static Reconstructor rec;
    return rec;
}

Params params(float r, NormalMode normals, Mode mode = Mode::Adaptive) {
    Params p;
    p.particle_radius = r;
    p.normals = normals;
    p.mode = mode;
    return p;
}

glm::dvec3 at(const std::vector<float>& v, std::size_t i) { return glm::dvec3(v[3 * i], v[3 * i + 1], v[3 * i + 2]); }

/// Fraction of vertices whose normals in `a` and `b` have a positive dot product.
double agreeing(const std::vector<float>& a, const std::vector<float>& b) {
    std::size_t ok = 0;
    for (std::size_t v = 0; v < a.size() / 3; ++v) ok += glm::dot(at(a, v), at(b, v)) > 0.0;
    return double(ok) / double(a.size() / 3);
}

void require_unit(const std::vector<float>& n) {
    for (std::size_t v = 0; v < n.size() / 3; ++v) {
        INFO("vertex " << v);
        REQUIRE(glm::length(at(n, v)) == Approx(1.0).margin(1e-6));
    }
}

/// A velocity that is an affine function of position, u(x) = M x + b.
glm::dvec3 affine_velocity(glm::dvec3 x) {
    const glm::dmat3 M(0.5, -1.0, 2.0, 1.5, 0.25, -0.75, -2.0, 1.0, 0.5);
    return M * x + glm::dvec3(0.1, -0.2, 0.3);
}

ParticleAttribute velocity_of(const ParticleSet& s) {
    ParticleAttribute a{"velocity", 3, {}};
    for (std::size_t i = 0; i < s.size(); ++i) {
        const glm::dvec3 u = affine_velocity(at(s.positions, i));
        a.values.insert(a.values.end(), {float(u.x), float(u.y), float(u.z)});
    }
    return a;
}

/// A ball of radius 20r without terraces: concentric shells 2r apart, each a Fibonacci spiral of
/// points about 2r apart, centred at c.
std::vector<float> smooth_ball(float r, glm::dvec3 c) {
    std::vector<float> xyz = {float(c.x), float(c.y), float(c.z)};
    const double golden = 3.14159265358979 * (3.0 - std::sqrt(5.0));
    for (int shell = 1; shell <= 10; ++shell) {
        const double radius = 2.0 * r * shell;
        const int n = int(std::lround(4.0 * 3.14159265358979 * radius * radius / (4.0 * r * r)));
        for (int i = 0; i < n; ++i) {
            const double z = 1.0 - 2.0 * (i + 0.5) / n, rho = std::sqrt(1.0 - z * z), phi = golden * i;
            const glm::dvec3 p = c + radius * glm::dvec3(rho * std::cos(phi), rho * std::sin(phi), z);
            xyz.insert(xyz.end(), {float(p.x), float(p.y), float(p.z)});
        }
    }
    return xyz;
}

}  // namespace

TEST_CASE("gradient normals of one particle are radial to 1e-5: the field is |x - c| - r there", "[normals]") {
    const float xyz[3] = {1.0f, -2.0f, 3.0f};
    const Mesh m = reconstructor().reconstruct(xyz, 1, params(0.1f, NormalMode::Gradient));
    REQUIRE(m.normals.size() == m.positions.size());
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
        const glm::dvec3 radial = glm::normalize(at(m.positions, v) - glm::dvec3(1.0, -2.0, 3.0));
        INFO("vertex " << v);
        REQUIRE(glm::length(at(m.normals, v) - radial) < 1e-5);
    }
}

TEST_CASE("normals on a ball point radially outward in every mode", "[normals]") {
    const float r = 0.025f;
    const glm::dvec3 c(0.3, -0.2, 0.1);
    const std::vector<float> ball = smooth_ball(r, c);
    for (NormalMode mode : {NormalMode::Gradient, NormalMode::Area})
        for (Mode grid : {Mode::Adaptive, Mode::Uniform}) {
            const Mesh m = reconstructor().reconstruct(ball.data(), ball.size() / 3, params(r, mode, grid));
            INFO((mode == NormalMode::Gradient ? "gradient" : "area") << (grid == Mode::Adaptive ? " adaptive" : " uniform"));
            REQUIRE(m.normals.size() == m.positions.size());
            require_unit(m.normals);
            // measured: every vertex within 3 (gradient) and 5.4 (area) degrees of the radius
            double worst = 1.0;
            for (std::size_t v = 0; v < m.vertex_count(); ++v)
                worst = std::min(worst, glm::dot(at(m.normals, v), glm::normalize(at(m.positions, v) - c)));
            CHECK(worst > 0.99);
        }
}

TEST_CASE("gradient normals agree with the mesh's area-weighted normals on every generated scene", "[normals]") {
    const float r = 0.025f;
    for (const std::string& name : scene_names()) {
        const ParticleSet s = generate_scene(name, r, 2);
        const Mesh m = reconstructor().reconstruct(s.positions.data(), s.size(), params(r, NormalMode::Gradient));
        INFO(name);
        require_unit(m.normals);
        // Measured: 99.8% or more on the generated scenes and the ../shared/data frames; the rest
        // sit in thin gaps and saddles where the field's gradient is weak and the mesh only
        // approximates its zero set (docs/operations.md, "Normals and attributes").
        CHECK(agreeing(m.normals, area_weighted_normals(m)) > 0.995);
    }
}

TEST_CASE("gradient normals agree with the area-weighted ones on the dam-break frame", "[normals][shared]") {
    TRILEVEL_REQUIRE_SHARED_DATA(dir);
    const ParticleSet s = read_particles((dir / "dam_break_frame_23_24389_particles.bgeo").string());
    const Mesh m = reconstructor().reconstruct(s.positions.data(), s.size(), params(0.025f, NormalMode::Gradient));
    require_unit(m.normals);
    CHECK(agreeing(m.normals, area_weighted_normals(m)) > 0.995);
}

TEST_CASE("area-weighted normals of a tetrahedron are the normalised sums of its face normals", "[normals]") {
    Mesh m;
    m.positions = {0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 4};
    m.triangles = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};  // counter-clockwise from outside
    const auto n = area_weighted_normals(m);
    // face cross products: (0, 0, -6), (0, -8, 0), (-12, 0, 0) and (12, 8, 6) for the slanted face
    const glm::dvec3 expect[4] = {{-12, -8, -6}, {12, 0, 0}, {0, 8, 0}, {0, 0, 6}};
    for (std::size_t v = 0; v < 4; ++v) {
        INFO("vertex " << v);
        CHECK(glm::length(at(n, v) - glm::normalize(expect[v])) < 1e-6);
    }
    // a vertex whose triangles have no area gets no direction
    m.positions[3] = 0;
    m.positions[7] = 0;
    m.positions[11] = 0;
    CHECK(at(area_weighted_normals(m), 0) == glm::dvec3(0.0));
}

TEST_CASE("a vertex out of every particle's reach keeps its area-weighted normal", "[normals]") {
    const float xyz[3] = {0, 0, 0};
    Mesh m;
    m.positions = {0.09f, 0, 0, 5, 5, 5};  // the first within R = 0.1: the gradient is radial, +x
    const std::vector<float> fallback = {0, 1, 0, 0, 0, 1};
    const auto grid = vertex_particle_grid(xyz, 1, 0.025f, 0.1f);
    const auto n = gradient_normals(m, grid, 0.025f, 0.1f, fallback);
    CHECK(glm::length(at(n, 0) - glm::dvec3(1, 0, 0)) < 1e-6);
    CHECK(at(n, 1) == glm::dvec3(0, 0, 1));
}

TEST_CASE("the closed-form eigenvalue agrees with the reference's QR iterations", "[normals]") {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-3.0, 3.0);
    for (int i = 0; i < 20000; ++i) {
        double J[3][3];
        for (auto& row : J)
            for (double& x : row) x = u(rng);
        if (i % 4 == 0)  // symmetric: three real roots
            for (int a = 0; a < 3; ++a)
                for (int b = 0; b < a; ++b) J[a][b] = J[b][a];
        INFO("matrix " << i);
        REQUIRE(largest_real_eigenvalue_cubic(J) == Approx(reference::largest_real_eigenvalue(J)).margin(1e-6));
    }
}

TEST_CASE("attributes: constants exactly, affine velocities at the kernel-weighted mean position", "[attributes]") {
    const float r = 0.025f;
    const ParticleSet s = generate_scene("pool-and-drop", r, 1);
    ParticleAttribute density{"density", 1, std::vector<float>(s.size(), 998.25f)};
    Stats st;
    const Mesh m = reconstructor().reconstruct(s.positions.data(), s.size(), params(r, NormalMode::None), &st,
                                               {velocity_of(s), density});
    REQUIRE(m.attributes.size() == 2);
    REQUIRE(m.attributes[0].name == "velocity");
    REQUIRE(m.attributes[0].components == 3);
    REQUIRE(m.attributes[0].values.size() == 3 * m.vertex_count());
    REQUIRE(m.attributes[1].name == "density");
    REQUIRE(m.attributes[1].values == std::vector<float>(m.vertex_count(), 998.25f));
    // Shepard weights k_j / sum k reproduce affine functions at xbar = sum k_j x_j / sum k_j, the
    // weighted mean the scalar field computes with the same kernel (reference implementation).
    std::vector<glm::vec3> x(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) x[i] = glm::vec3(at(s.positions, i));
    const reference::ParticleGrid grid(x, 4 * r);
    double worst = 0.0, worst_at_vertex = 0.0;
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
        const glm::vec3 p(at(m.positions, v));
        const glm::dvec3 expect = affine_velocity(reference::scalar_field_sample(p, grid, r).xbar);
        const glm::dvec3 got = at(m.attributes[0].values, v);
        worst = std::max(worst, glm::length(got - expect));
        worst_at_vertex = std::max(worst_at_vertex, glm::length(got - affine_velocity(glm::dvec3(p))));
    }
    CHECK(worst < 1e-5);  // float rounding of velocities of magnitude ~3
    // and close to the velocity at the vertex itself: |M| |xbar - v| with |xbar - v| < R
    CHECK(worst_at_vertex < 3.5 * 4 * r);
    CHECK(worst_at_vertex > worst);
}

TEST_CASE("a vertex with no particle within R takes its nearest particle's value", "[attributes]") {
    const float xyz[9] = {0, 0, 0, 1, 0, 0, 5, 5, 5};
    const ParticleAttribute a{"id", 1, {10, 20, 30}};
    Mesh m;
    m.positions = {0.9f, 0.3f, 0.0f, 4.0f, 4.0f, 4.2f, 0.02f, 0, 0};
    const float r = 0.025f, R = 0.1f;
    const auto grid = vertex_particle_grid(xyz, 3, r, R);
    const auto out = interpolate_attributes(m, grid, xyz, 3, R, {a});
    REQUIRE(out.size() == 1);
    CHECK(out[0].values == std::vector<float>{20, 30, 10});
}

TEST_CASE("normals and attributes are bit-identical across runs and thread counts and leave the geometry as it was", "[normals][attributes][determinism]") {
    const float r = 0.025f;
    const ParticleSet s = generate_scene("dam-break", r, 3);
    const std::vector<ParticleAttribute> attrs = {velocity_of(s)};
    Stats st;
    const Mesh plain = reconstructor().reconstruct(s.positions.data(), s.size(), params(r, NormalMode::None), &st);
    CHECK(plain.normals.empty());
    CHECK(plain.attributes.empty());
    for (const auto& [name, ms] : st.time_ms) CHECK((name != "normals" && name != "attributes"));
    for (NormalMode mode : {NormalMode::Gradient, NormalMode::Area}) {
        const Mesh a = reconstructor().reconstruct(s.positions.data(), s.size(), params(r, mode), &st, attrs);
        std::vector<std::string> stages;
        for (const auto& [name, ms] : st.time_ms) stages.push_back(name);
        CHECK(std::find(stages.begin(), stages.end(), "normals") != stages.end());
        CHECK(std::find(stages.begin(), stages.end(), "attributes") != stages.end());
        CHECK(stages.back() == "total");
        Mesh b;
        {
            tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
            b = reconstructor().reconstruct(s.positions.data(), s.size(), params(r, mode), nullptr, attrs);
        }
        REQUIRE(same_mesh(a, b));
        Mesh geometry = a;  // the normals and attributes leave the mesh itself as it was
        geometry.normals.clear();
        geometry.attributes.clear();
        REQUIRE(same_mesh(geometry, plain));
    }
}

TEST_CASE("unusable attributes and normal modes are clear errors", "[attributes][errors]") {
    const float xyz[6] = {0, 0, 0, 0.05f, 0, 0};
    auto& rec = reconstructor();
    const Params p = params(0.025f, NormalMode::None);
    auto fails = [&](const ParticleAttribute& a) { return rec.reconstruct(xyz, 2, p, nullptr, {a}); };
    REQUIRE_THROWS_WITH(fails({"v", 2, {1, 2, 3, 4}}), Catch::Contains("'v'") && Catch::Contains("2 components"));
    REQUIRE_THROWS_WITH(fails({"v", 3, {1, 2, 3}}), Catch::Contains("'v'") && Catch::Contains("3 values for 2 particles"));
    REQUIRE_THROWS_WITH(fails({"d", 1, {1, NAN}}), Catch::Contains("'d'") && Catch::Contains("particle 1") && Catch::Contains("non-finite"));
    REQUIRE_THROWS_WITH(fails({"my density", 1, {1, 2}}), Catch::Contains("white space"));
    REQUIRE_THROWS_WITH(fails({"", 1, {1, 2}}), Catch::Contains("empty name"));
    REQUIRE_THROWS_WITH(rec.reconstruct(xyz, 2, p, nullptr, {{"d", 1, {1, 2}}, {"d", 1, {1, 2}}}), Catch::Contains("'d' is given twice"));
    Params bad = p;
    bad.normals = static_cast<NormalMode>(7);
    REQUIRE_THROWS_WITH(rec.reconstruct(xyz, 2, bad), Catch::Contains("normals"));
}

TEST_CASE("normals and attributes round-trip bit-exactly through PLY and VTK, normals through OBJ", "[io][normals][attributes]") {
    TempDir tmp;
    const float r = 0.025f;
    const ParticleSet s = generate_scene("sphere", r, 1);
    ParticleAttribute density{"density", 1, {}};
    for (std::size_t i = 0; i < s.size(); ++i) density.values.push_back(1000.0f + float(i % 17) * 0.37f);
    const Mesh m = reconstructor().reconstruct(s.positions.data(), s.size(), params(r, NormalMode::Gradient), nullptr,
                                               {velocity_of(s), density});
    for (const std::string ext : {"ply", "vtk", "obj"}) {
        INFO(ext);
        const std::string f = tmp.file("m." + ext);
        write_mesh(f, m);
        const Mesh back = read_mesh(f);
        REQUIRE(same_bits(back.positions, m.positions));
        REQUIRE(back.triangles == m.triangles);
        REQUIRE(same_bits(back.normals, m.normals));
        if (ext == "obj") {
            REQUIRE(back.attributes.empty());  // OBJ has no per-vertex attributes: left out
            continue;
        }
        REQUIRE(back.vertex_level == m.vertex_level);
        REQUIRE(back.attributes.size() == 2);
        for (std::size_t a = 0; a < 2; ++a) {
            CHECK(back.attributes[a].name == m.attributes[a].name);
            CHECK(back.attributes[a].components == m.attributes[a].components);
            CHECK(same_bits(back.attributes[a].values, m.attributes[a].values));
        }
    }
    // The PLY header names them as documented.
    std::ifstream in(tmp.file("m.ply"), std::ios::binary);
    std::string head((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    head = head.substr(0, head.find("end_header"));
    CHECK(head.find("property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\n"
                    "property float nz\nproperty uchar level\nproperty float velocity_x\nproperty float velocity_y\n"
                    "property float velocity_z\nproperty float density\n") != std::string::npos);
    // With colours too, every property keeps its place.
    MeshWriteOptions colours;
    colours.color_levels = true;
    write_mesh(tmp.file("c.ply"), m, colours);
    const Mesh c = read_mesh(tmp.file("c.ply"));
    CHECK(same_bits(c.normals, m.normals));
    CHECK(same_bits(c.attributes[1].values, m.attributes[1].values));
}

TEST_CASE("writers refuse attributes they cannot store unambiguously", "[io][attributes][errors]") {
    TempDir tmp;
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    m.triangles = {0, 1, 2};
    auto fails = [&](const std::string& file, const VertexAttribute& a) {
        Mesh x = m;
        x.attributes = {a};
        write_mesh(tmp.file(file), x);
    };
    REQUIRE_THROWS_WITH(fails("a.ply", {"level", 1, {1, 2, 3}}), Catch::Contains("'level'") && Catch::Contains("collides"));
    Mesh two = m;
    two.attributes = {{"v", 3, std::vector<float>(9, 1.0f)}, {"v_y", 1, {1, 2, 3}}};
    REQUIRE_THROWS_WITH(write_mesh(tmp.file("two.vtk"), two), Catch::Contains("'v_y'") && Catch::Contains("collides"));
    REQUIRE_THROWS_WITH(fails("a.vtk", {"x", 1, {1, 2, 3}}), Catch::Contains("collides"));
    REQUIRE_THROWS_WITH(fails("a.ply", {"a b", 1, {1, 2, 3}}), Catch::Contains("white space"));
    REQUIRE_THROWS_WITH(fails("a.ply", {"v", 3, {1, 2, 3}}), Catch::Contains("'v' has 3 values for 3 vertices"));
    REQUIRE_THROWS_WITH(fails("a.ply", {"v", 1, {1, NAN, 3}}), Catch::Contains("non-finite"));
    Mesh n = m;
    n.normals = {0, 0, 1};
    REQUIRE_THROWS_WITH(write_mesh(tmp.file("n.ply"), n), Catch::Contains("3 normal components for 3 vertices"));
    REQUIRE(std::filesystem::is_empty(tmp.path));
    // Attributes never reach an OBJ file, and that is no error.
    Mesh o = m;
    o.attributes = {{"density", 1, {1, 2, 3}}};
    write_mesh(tmp.file("o.obj"), o);
    REQUIRE(read_mesh(tmp.file("o.obj")).attributes.empty());
}
