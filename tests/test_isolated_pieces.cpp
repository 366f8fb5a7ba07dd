// Isolated pieces at level 3 (paper Fig. 1): the groups of coarse surface cells against a search
// between every pair of cells, the promotion of small groups only, and compact droplets that now keep
// the volume uniform r gives them.
#include <algorithm>
#include <numeric>
#include <queue>
#include <random>

#include "isolated_pieces.hpp"
#include "mesh_test_support.hpp"
#include "test_support.hpp"
#include "trilevel/trilevel.hpp"

using namespace trilevel;

namespace {

/// Group sizes by a breadth-first search over every pair of cells (quadratic: small sets only); two
/// cells are neighbours when they share a face.
std::vector<std::uint32_t> group_sizes_by_search(const std::vector<CoarseCell>& cells) {
    const std::size_t n = cells.size();
    std::vector<int> group(n, -1);
    std::vector<std::uint32_t> size_of;
    for (std::size_t s = 0; s < n; ++s) {
        if (group[s] >= 0) continue;
        const int g = int(size_of.size());
        size_of.push_back(0);
        std::queue<std::size_t> todo;
        todo.push(s);
        group[s] = g;
        while (!todo.empty()) {
            const std::size_t i = todo.front();
            todo.pop();
            ++size_of[std::size_t(g)];
            for (std::size_t j = 0; j < n; ++j) {
                const glm::ivec3 d = glm::abs(cells[j].coord - cells[i].coord);
                if (group[j] < 0 && d.x + d.y + d.z == 1) group[j] = g, todo.push(j);  // a shared face
            }
        }
    }
    std::vector<std::uint32_t> out(n);
    for (std::size_t i = 0; i < n; ++i) out[i] = size_of[std::size_t(group[i])];
    return out;
}

/// Each cell's group size, from cell_groups.
std::vector<std::uint32_t> sizes_of(const std::vector<CoarseCell>& cells) {
    const CellGroups g = cell_groups(cells);
    std::vector<std::uint32_t> out;
    for (std::uint32_t k : g.group) out.push_back(g.size[k]);
    return out;
}

/// Compact droplet: the points of the 2r lattice within `radius` of the centre.
std::vector<float> droplet(float r, float radius, glm::vec3 centre) {
    std::vector<float> x;
    const int k = int(std::ceil(radius / (2 * r))) + 1;
    for (int c = -k; c <= k; ++c)
        for (int b = -k; b <= k; ++b)
            for (int a = -k; a <= k; ++a) {
                const glm::vec3 p = 2 * r * glm::vec3(a, b, c);
                if (glm::length(p) <= radius * (1 + 1e-6f)) x.insert(x.end(), {centre.x + p.x, centre.y + p.y, centre.z + p.z});
            }
    return x;
}

}  // namespace

TEST_CASE("cell groups match a search over every pair of cells", "[isolated]") {
    std::mt19937 rng(5);
    for (float density : {0.05f, 0.15f, 0.3f}) {
        std::vector<CoarseCell> cells;
        std::bernoulli_distribution keep(density);
        for (int z = 0; z < 14; ++z)
            for (int y = 0; y < 14; ++y)
                for (int x = 0; x < 14; ++x)
                    if (keep(rng)) cells.push_back({{x, y, z}, 2});
        const std::vector<std::uint32_t> expected = group_sizes_by_search(cells);
        CHECK(sizes_of(cells) == expected);  // in lattice::pack order, as the surface stage gives them
        // In any order: shuffled, the sizes follow their cells.
        std::vector<std::size_t> perm(cells.size());
        std::iota(perm.begin(), perm.end(), std::size_t{0});
        std::shuffle(perm.begin(), perm.end(), rng);
        std::vector<CoarseCell> shuffled;
        std::vector<std::uint32_t> shuffled_expected;
        for (std::size_t i : perm) shuffled.push_back(cells[i]), shuffled_expected.push_back(expected[i]);
        CHECK(sizes_of(shuffled) == shuffled_expected);
        // Not every set is one group or all singletons.
        CHECK(*std::max_element(expected.begin(), expected.end()) > 1);
        CHECK(std::count(expected.begin(), expected.end(), 1u) > 0);
    }
}

TEST_CASE("isolated pieces of up to the limit turn level 3 and forced", "[isolated]") {
    // Three groups: 2 cells sharing a face, a 4 x 4 x 4 block, and a lone cell far away.
    std::vector<CoarseCell> cells = {{{0, 0, 0}, 2}, {{0, 0, 1}, 2}};
    for (const CoarseCell& c : test::block_cells({4, 4, 4}, {10, 0, 0}, 2)) cells.push_back(c);
    cells.push_back({{30, 30, 30}, 3});
    std::vector<std::uint8_t> forced(cells.size(), 0);
    CHECK(promote_isolated_pieces(cells, forced, 63) == 2);  // the pair; the lone cell was level 3
    for (std::size_t i = 0; i < cells.size(); ++i) {
        const bool small = i < 2 || i + 1 == cells.size();
        INFO("cell " << i);
        CHECK(int(cells[i].level) == (small ? 3 : 2));
        CHECK(int(forced[i]) == (small ? 1 : 0));
    }
    CHECK(promote_isolated_pieces(cells, forced, 64) == 64);  // the block has 64 cells
    CHECK(promote_isolated_pieces(cells, forced, 0) == 0);    // 0: off
}

TEST_CASE("isolated pieces hold their level around the limit over frames", "[isolated][history]") {
    // Groups of 60 cells (a 3 x 4 x 5 block) and 70 (2 x 5 x 7), at limit 64 with hysteresis 0.2:
    // a group whose cells were mostly level 3 stays isolated up to 76 cells, one that was mostly
    // level 2 becomes isolated at 51, a new one at 64.
    const std::vector<CoarseCell> small = test::block_cells({3, 4, 5}, {0, 0, 0}, 2);
    const std::vector<CoarseCell> large = test::block_cells({2, 5, 7}, {0, 0, 0}, 2);
    auto promoted = [](std::vector<CoarseCell> cells, std::uint8_t before, std::size_t earlier_cells) {
        std::vector<std::uint8_t> forced(cells.size(), 0), previous(cells.size(), 0);
        std::fill(previous.begin(), previous.begin() + std::ptrdiff_t(earlier_cells), before);
        return promote_isolated_pieces(cells, forced, 64, previous, 0.2f);
    };
    CHECK(promoted(small, 0, 0) == 60);          // new: the plain limit
    CHECK(promoted(small, 2, 60) == 0);          // was level 2: needs 51 cells or fewer
    CHECK(promoted(small, 3, 60) == 60);
    CHECK(promoted(large, 3, 70) == 70);         // was level 3: held up to 76
    CHECK(promoted(large, 3, 35) == 70);         // half its cells were there, all level 3
    CHECK(promoted(large, 0, 0) == 0);
    CHECK(promoted(large, 2, 70) == 0);
    std::vector<CoarseCell> cells = large;       // without history or hysteresis: the plain limit
    std::vector<std::uint8_t> forced(cells.size(), 0), previous(cells.size(), 3);
    CHECK(promote_isolated_pieces(cells, forced, 64, previous, 0.0f) == 0);
}

TEST_CASE("compact droplets of 8 to 33 particles keep the volume uniform r gives them", "[isolated][e2e]") {
    // Before the rule, their curvature (a sum over few neighbours, paper eq. 1) left them at level 2,
    // with 64% (8 particles), 86% (19) and 89% (33) of uniform r's volume.
    const float r = 0.025f;
    Reconstructor rec;
    Params adaptive;
    adaptive.particle_radius = r;
    Params uniform = adaptive;
    uniform.mode = Mode::Uniform;
    for (float radius : {1.8f * r, 2.9f * r, 4.1f * r}) {
        std::vector<float> x = radius < 2 * r ? std::vector<float>{} : droplet(r, radius, {0.31f, 0.28f, 0.25f});
        if (x.empty())  // a 2 x 2 x 2 cube: 7 neighbours each, too many to be thin
            for (const glm::vec3& p : test::lattice_points({2, 2, 2}, {0.31f, 0.28f, 0.25f}, 2 * r))
                x.insert(x.end(), {p.x, p.y, p.z});
        const std::size_t n = x.size() / 3;
        INFO(n << " particles");
        Stats st;
        const Mesh a = rec.reconstruct(x.data(), n, adaptive, &st);
        const Mesh u = rec.reconstruct(x.data(), n, uniform);
        test::require_closed(a, "droplet");
        CHECK(st.isolated_piece_cells > 0);
        CHECK(st.surface_cells_level2 == 0);
        CHECK(test::signed_volume(a) == Approx(test::signed_volume(u)).epsilon(1e-3));
    }
    // A body of 2,000 particles is no isolated piece: its flat faces stay level 2.
    std::vector<float> block;
    for (const glm::vec3& p : test::lattice_points({20, 10, 10}, {0.1f, 0.1f, 0.1f}, 2 * r)) block.insert(block.end(), {p.x, p.y, p.z});
    Stats st;
    test::require_closed(rec.reconstruct(block.data(), block.size() / 3, adaptive, &st), "block");
    CHECK(st.isolated_piece_cells == 0);
    CHECK(st.surface_cells_level2 > 0);
}
