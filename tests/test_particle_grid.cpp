// The frame's particle grid (core/particle_grid.hpp) against a brute-force search, its visit order
// against the reference's hash grid (which the vertex stages used before: their bits depend on
// it), both storage layouts, far-off coordinates, and the field at a point against the reference.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <tuple>
#include <vector>

#include <glm/glm.hpp>

#include "core/field_at_point.hpp"
#include "core/particle_grid.hpp"
#include "reference/reference_stages.hpp"
#include "test_support.hpp"
#include "trilevel/trilevel.hpp"

using namespace trilevel;

namespace {

std::vector<float> random_particles(std::size_t n, float extent, glm::vec3 shift, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, extent);
    std::vector<float> xyz(3 * n);
    for (std::size_t i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) xyz[3 * i + a] = shift[a] + u(rng);
    return xyz;
}

glm::vec3 particle(const std::vector<float>& xyz, std::size_t j) { return {xyz[3 * j], xyz[3 * j + 1], xyz[3 * j + 2]}; }

/// Every particle within `radius` (exact double distance) of p, by index.
std::vector<std::uint32_t> brute_force(const std::vector<float>& xyz, glm::vec3 p, double radius) {
    std::vector<std::uint32_t> out;
    for (std::size_t j = 0; j < xyz.size() / 3; ++j) {
        const glm::dvec3 d = glm::dvec3(p) - glm::dvec3(particle(xyz, j));
        if (glm::dot(d, d) < radius * radius) out.push_back(std::uint32_t(j));
    }
    return out;
}

/// The candidates the grid visits within `radius`, in visit order.
std::vector<std::uint32_t> within(const ParticleGrid& g, glm::vec3 p, double radius) {
    std::vector<std::uint32_t> out;
    g.for_each_candidate(p, radius, [&](std::uint32_t j, glm::vec3 x) {
        const glm::dvec3 d = glm::dvec3(p) - glm::dvec3(x);
        if (glm::dot(d, d) < radius * radius) out.push_back(j);
    });
    return out;
}

}  // namespace

TEST_CASE("the particle grid finds exactly the particles within any radius, in (cell, index) order, in both layouts", "[particle_grid]") {
    // (A search that may stop visits them rows nearest first: checked below.)
    const float cell = 0.1f;
    const std::vector<float> xyz = random_particles(4000, 1.0f, glm::vec3(-0.3f, 0.2f, 5.0f), 7);
    const std::size_t n = xyz.size() / 3;
    const ParticleGrid dense(xyz.data(), n, cell), sorted(xyz.data(), n, cell, 1);
    REQUIRE(dense.dense());
    REQUIRE(!sorted.dense());
    REQUIRE(dense.size() == n);
    glm::vec3 lo = particle(xyz, 0);
    for (std::size_t j = 0; j < n; ++j) lo = glm::min(lo, particle(xyz, j));
    const auto cell_of = [&](std::uint32_t j) {
        const glm::ivec3 c(glm::floor((particle(xyz, j) - lo) / cell));
        return std::make_tuple(c.z, c.y, c.x, j);
    };
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-0.5f, 1.5f);
    std::size_t found = 0;
    for (int q = 0; q < 400; ++q) {
        const glm::vec3 p = glm::vec3(-0.3f, 0.2f, 5.0f) + glm::vec3(u(rng), u(rng), u(rng));
        for (double radius : {0.0, 0.03, 0.1, 0.1 * (1 - 1e-7), 0.17, 0.25}) {
            std::vector<std::uint32_t> got = within(dense, p, radius);
            REQUIRE(within(sorted, p, radius) == got);
            REQUIRE(std::is_sorted(got.begin(), got.end(), [&](auto a, auto b) { return cell_of(a) < cell_of(b); }));
            std::sort(got.begin(), got.end());
            REQUIRE(got == brute_force(xyz, p, radius));
            found += got.size();
            // A callback returning bool may stop the search: it visits the same candidates, rows
            // nearest first (z rows outwards from p's, then y rows likewise), and a stopped search's
            // visits are the first of those.
            std::vector<std::uint32_t> all, nearest_first, prefix;
            dense.for_each_candidate(p, radius, [&](std::uint32_t j, glm::vec3) { all.push_back(j); });
            for (const ParticleGrid* g : {&dense, &sorted}) {
                nearest_first.clear();
                g->for_each_candidate(p, radius, [&](std::uint32_t j, glm::vec3) {
                    nearest_first.push_back(j);
                    return false;
                });
                std::vector<std::uint32_t> a = all, b = nearest_first;
                std::sort(a.begin(), a.end());
                std::sort(b.begin(), b.end());
                REQUIRE(a == b);
                const int zp = int(std::floor((double(p.z) - double(lo.z)) / double(cell)));  // as the grid takes it
                for (std::size_t i = 1; i < nearest_first.size(); ++i)
                    REQUIRE(std::abs(std::get<0>(cell_of(nearest_first[i])) - zp) >= std::abs(std::get<0>(cell_of(nearest_first[i - 1])) - zp));
            }
            const std::size_t stop = nearest_first.size() / 2;
            dense.for_each_candidate(p, radius, [&](std::uint32_t j, glm::vec3) {
                prefix.push_back(j);
                return prefix.size() > stop;
            });
            REQUIRE(prefix.size() == std::min(stop + 1, nearest_first.size()));
            REQUIRE(std::equal(prefix.begin(), prefix.end(), nearest_first.begin()));
        }
    }
    CHECK(found > 10000);  // the queries do reach particles
}

TEST_CASE("the particle grid visits the neighbours in the reference hash grid's order", "[particle_grid]") {
    // The vertex stages' sums keep their bits only if the accepted particles come in this order.
    const float R = 0.1002f;
    const std::vector<float> xyz = random_particles(3000, 0.8f, glm::vec3(1.0f, -2.0f, 0.5f), 11);
    const std::size_t n = xyz.size() / 3;
    std::vector<glm::vec3> x(n);
    for (std::size_t j = 0; j < n; ++j) x[j] = particle(xyz, j);
    const reference::ParticleGrid ref(x, R);
    const ParticleGrid grid(xyz.data(), n, R);
    const double R2 = double(R) * R;
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-0.1f, 0.9f);
    for (int q = 0; q < 500; ++q) {
        const glm::vec3 p = glm::vec3(1.0f, -2.0f, 0.5f) + glm::vec3(u(rng), u(rng), u(rng));
        std::vector<int> expect;
        ref.for_each_neighbour(p, [&](int j, glm::vec3, double) { expect.push_back(j); });
        std::vector<int> got;
        grid.for_each_candidate(p, R, [&](std::uint32_t j, glm::vec3 xj) {
            const glm::vec3 d = p - xj;  // the reference's test: float differences, squared in double
            if (double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z < R2) got.push_back(int(j));
        });
        REQUIRE(got == expect);
    }
}

TEST_CASE("the particle grid misses no neighbour far from its origin", "[particle_grid]") {
    // Two clusters 3e4 cells apart: the float cell coordinates round by more than the gap
    // between a radius and the cell edge, which the search window allows for.
    std::vector<float> xyz = random_particles(500, 0.05f, glm::vec3(0.0f), 1);
    const std::vector<float> far = random_particles(2000, 0.3f, glm::vec3(3000.0f, 3000.0f, 3000.0f), 2);
    xyz.insert(xyz.end(), far.begin(), far.end());
    const std::size_t n = xyz.size() / 3;
    const ParticleGrid grid(xyz.data(), n, 0.1f);
    CHECK(!grid.dense());  // 3e4^3 cells: the sorted layout
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(0.0f, 0.3f);
    for (int q = 0; q < 300; ++q) {
        const glm::vec3 p = glm::vec3(3000.0f) + glm::vec3(u(rng), u(rng), u(rng));
        std::vector<std::uint32_t> got = within(grid, p, 0.1);
        std::sort(got.begin(), got.end());
        REQUIRE(got == brute_force(xyz, p, 0.1));
    }
}

TEST_CASE("an empty particle grid finds nothing, a bad cell edge is a clear error", "[particle_grid][errors]") {
    const ParticleGrid empty(nullptr, 0, 0.1f);
    int calls = 0;
    empty.for_each_candidate(glm::vec3(0.0f), 1.0, [&](std::uint32_t, glm::vec3) { ++calls; });
    CHECK(calls == 0);
    const float one[3] = {1.0f, 2.0f, 3.0f};
    const ParticleGrid single(one, 1, 0.1f);
    single.for_each_candidate(glm::vec3(1.0f, 2.0f, 3.0f), 0.0, [&](std::uint32_t j, glm::vec3) { calls += int(j) + 1; });
    CHECK(calls == 1);
    single.for_each_candidate(glm::vec3(NAN), 1.0, [&](std::uint32_t, glm::vec3) { ++calls; });
    CHECK(calls == 1);
    REQUIRE_THROWS_WITH(ParticleGrid(one, 1, 0.0f), "particle grid: cell edge must be finite and > 0, got 0.000000");
    REQUIRE_THROWS_WITH(ParticleGrid(one, 1, NAN), Catch::StartsWith("particle grid: cell edge must be finite and > 0"));
}

TEST_CASE("the field at a point has the reference's bits with the closed-form eigenvalue", "[normals][particle_grid]") {
    // host/vertex_normals.cpp evaluates it; the reference keeps its own copy as the kernels' oracle.
    std::mt19937 rng(13);
    const double r = 0.025, R = 4 * r;
    std::uniform_real_distribution<double> u(-R, R);
    std::size_t compared = 0;
    for (int q = 0; q < 2000; ++q) {
        std::vector<glm::dvec3> y;
        const int count = int(rng() % 40);
        while (int(y.size()) < count) {
            const glm::dvec3 c(u(rng), u(rng), u(rng));
            if (glm::dot(c, c) < R * R) y.push_back(c);
        }
        const double phi = field_from_offsets(y.data(), y.size(), r, R);
        const double expect = reference::field_from_offsets(y.data(), y.size(), r, R, largest_real_eigenvalue_cubic).phi;
        REQUIRE(std::memcmp(&phi, &expect, sizeof phi) == 0);
        compared += phi != R;
    }
    CHECK(compared > 1500);
}
