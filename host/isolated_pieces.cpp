#include "isolated_pieces.hpp"

#include <algorithm>
#include <array>
#include <numeric>

#include "core/lattice.hpp"
#include "core/union_find.hpp"

namespace trilevel {
namespace {

/// A run of cells with one (y, z), sorted by x: positions [begin, end) of the sorted list.
struct Row {
    int y, z;
    std::uint32_t begin, end;
};

/// (y, z) before (y2, z2) in pack order.
bool before(int y, int z, int y2, int z2) { return z != z2 ? z < z2 : y < y2; }

}  // namespace

CellGroups cell_groups(const std::vector<CoarseCell>& cells) {
    const std::size_t n = cells.size();
    // The cells in lattice::pack order (z, then y, then x): the surface stage's output order, so
    // this order is the identity there. Face neighbours then lie in the same row or in two earlier
    // rows, which a merge of sorted runs finds without a hash (a hash lookup per neighbour took 26
    // ms for x64's 128 k cells, this under 5).
    std::vector<std::uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    auto by_key = [&](std::uint32_t a, std::uint32_t b) { return lattice::pack(cells[a].coord) < lattice::pack(cells[b].coord); };
    if (!std::is_sorted(order.begin(), order.end(), by_key)) std::sort(order.begin(), order.end(), by_key);
    auto at = [&](std::uint32_t k) -> const glm::ivec3& { return cells[order[k]].coord; };

    std::vector<Row> rows;
    for (std::uint32_t k = 0; k < n; ++k)
        if (k == 0 || at(k).y != at(k - 1).y || at(k).z != at(k - 1).z) rows.push_back({at(k).y, at(k).z, k, k + 1});
        else rows.back().end = k + 1;

    UnionFind groups(n);
    // Joins the cells of rows a and b that share a face: the same x.
    auto join_rows = [&](const Row& a, const Row& b) {
        std::uint32_t j = b.begin;
        for (std::uint32_t i = a.begin; i < a.end && j < b.end; ++i) {
            while (j < b.end && at(j).x < at(i).x) ++j;
            if (j < b.end && at(j).x == at(i).x) groups.join(i, j);
        }
    };
    // The earlier rows that share faces with a row: y - 1 and z - 1. Each one's position in `rows`
    // only grows as the rows go on.
    static constexpr std::array<std::array<int, 2>, 2> earlier = {{{-1, 0}, {0, -1}}};
    std::array<std::size_t, 2> next{};
    for (std::size_t r = 0; r < rows.size(); ++r) {
        const Row& row = rows[r];
        for (std::uint32_t k = row.begin + 1; k < row.end; ++k)
            if (at(k).x == at(k - 1).x + 1) groups.join(k - 1, k);
        for (std::size_t e = 0; e < earlier.size(); ++e) {
            const int y = row.y + earlier[e][0], z = row.z + earlier[e][1];
            std::size_t& p = next[e];
            while (p < r && before(rows[p].y, rows[p].z, y, z)) ++p;
            if (p < r && rows[p].y == y && rows[p].z == z) join_rows(row, rows[p]);
        }
    }
    // Roots are the smallest position of their group in pack order; number the groups by their
    // first cell in the caller's order.
    CellGroups out;
    out.group.resize(n);
    std::vector<std::uint32_t> number(n, ~0u), root_of(n);
    for (std::uint32_t k = 0; k < n; ++k) root_of[order[k]] = groups.find(k);
    for (std::size_t i = 0; i < n; ++i) {
        std::uint32_t& g = number[root_of[i]];
        if (g == ~0u) g = std::uint32_t(out.size.size()), out.size.push_back(0);
        out.group[i] = g;
        ++out.size[g];
    }
    return out;
}

std::size_t promote_isolated_pieces(std::vector<CoarseCell>& cells, std::vector<std::uint8_t>& forced,
                                    std::size_t max_cells, const std::vector<std::uint8_t>& previous, float h) {
    if (max_cells == 0 || cells.empty()) return 0;
    const CellGroups groups = cell_groups(cells);
    std::vector<std::size_t> limit(groups.size.size(), max_cells);
    if (!previous.empty()) {
        std::vector<std::array<std::uint32_t, 2>> earlier(groups.size.size(), {0, 0});  // cells that were level 2, 3
        for (std::size_t i = 0; i < cells.size(); ++i)
            if (previous[i] == 2 || previous[i] == 3) ++earlier[groups.group[i]][previous[i] - 2u];
        for (std::size_t g = 0; g < limit.size(); ++g)
            if (earlier[g][0] + earlier[g][1] > 0)
                limit[g] = std::size_t(double(max_cells) * (earlier[g][1] >= earlier[g][0] ? 1.0 + h : 1.0 - h));
    }
    std::size_t promoted = 0;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        const std::uint32_t g = groups.group[i];
        if (groups.size[g] > limit[g]) continue;
        promoted += cells[i].level == 2;
        cells[i].level = 3;
        forced[i] = 1;
    }
    return promoted;
}

}  // namespace trilevel
