#include "domain_split.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <map>
#include <numeric>
#include <string>
#include <tuple>
#include <unordered_map>

#include "core/union_find.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {
namespace {

using CellKey = std::tuple<std::int64_t, std::int64_t, std::int64_t>;

struct CellKeyHash {
    std::size_t operator()(const CellKey& k) const {
        auto [x, y, z] = k;
        return std::size_t(x * 73856093LL) ^ std::size_t(y * 19349663LL) ^ std::size_t(z * 83492791LL);
    }
};

}  // namespace

std::string fmt(double v) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.3g", v);
    return buf;
}

Bounds bounds_of(const float* xyz, std::size_t n) {
    Bounds b;
    for (int k = 0; k < 3; ++k) {
        b.lo[k] = INFINITY;
        b.hi[k] = -INFINITY;
    }
    for (std::size_t i = 0; i < n; ++i)
        for (int k = 0; k < 3; ++k) {
            const double v = xyz[3 * i + k];
            if (!std::isfinite(v)) throw Error("particle " + std::to_string(i) + " has a non-finite coordinate");
            b.lo[k] = std::min(b.lo[k], v);
            b.hi[k] = std::max(b.hi[k], v);
            b.max_abs = std::max(b.max_abs, std::fabs(v));
        }
    return b;
}

std::vector<std::vector<std::uint32_t>> split_domain(const float* xyz, std::size_t n, double separation, double tile) {
    // 1. Particles into cells of edge separation / 2. Cells closer than `separation` (box to box)
    //    are joined when some pair of their particles is: the clusters are exactly the components
    //    of "closer than `separation`". Joined cells skip the pair test, so dense fluid costs one
    //    successful test per cell pair; only the gaps between clusters are searched in full.
    const double edge = 0.5 * separation;
    std::unordered_map<CellKey, std::uint32_t, CellKeyHash> cell_of_key;
    std::vector<CellKey> keys;
    std::vector<std::uint32_t> cell(n);
    for (std::size_t i = 0; i < n; ++i) {
        CellKey k{std::int64_t(std::floor(xyz[3 * i] / edge)), std::int64_t(std::floor(xyz[3 * i + 1] / edge)),
                  std::int64_t(std::floor(xyz[3 * i + 2] / edge))};
        auto [it, fresh] = cell_of_key.try_emplace(k, std::uint32_t(keys.size()));
        if (fresh) keys.push_back(k);
        cell[i] = it->second;
    }
    std::vector<std::vector<std::uint32_t>> members(keys.size());
    for (std::size_t i = 0; i < n; ++i) members[cell[i]].push_back(std::uint32_t(i));
    const double sep2 = separation * separation;
    auto close_pair = [&](std::uint32_t a, std::uint32_t b) {
        for (std::uint32_t i : members[a])
            for (std::uint32_t j : members[b]) {
                double d2 = 0;
                for (int k = 0; k < 3; ++k) {
                    const double d = double(xyz[3 * i + k]) - xyz[3 * j + k];
                    d2 += d * d;
                }
                if (d2 < sep2) return true;
            }
        return false;
    };
    UnionFind comp(keys.size());
    for (std::uint32_t c = 0; c < keys.size(); ++c) {
        auto [x, y, z] = keys[c];
        for (int dz = -2; dz <= 2; ++dz)
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx) {
                    // box-to-box distance, in cell edges: offsets of 2 leave one edge between the cells
                    const int gaps = (std::abs(dx) == 2) + (std::abs(dy) == 2) + (std::abs(dz) == 2);
                    if (gaps * edge * edge >= sep2) continue;
                    auto it = cell_of_key.find({x + dx, y + dy, z + dz});
                    if (it == cell_of_key.end() || it->second <= c) continue;  // each pair once
                    if (comp.find(c) != comp.find(it->second) && close_pair(c, it->second)) comp.join(c, it->second);
                }
    }
    // particles in one cell are within edge * sqrt(3) < separation of each other: already one component

    // 2. Bounds of each connected cluster.
    struct Cluster {
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    };
    std::unordered_map<std::uint32_t, Cluster> clusters;
    for (std::size_t i = 0; i < n; ++i) {
        Cluster& c = clusters[comp.find(cell[i])];
        for (int k = 0; k < 3; ++k) {
            c.lo[k] = std::min(c.lo[k], double(xyz[3 * i + k]));
            c.hi[k] = std::max(c.hi[k], double(xyz[3 * i + k]));
        }
    }

    // 3. Clusters narrower than `tile` share the group of the tile holding their low corner (a
    //    group then spans less than 2 * tile); wider ones get a group of their own.
    using GroupKey = std::tuple<int, std::int64_t, std::int64_t, std::int64_t>;  // (own group?, tile or root)
    std::unordered_map<std::uint32_t, GroupKey> group_of_root;
    for (const auto& [root, c] : clusters) {
        double extent = 0;
        for (int k = 0; k < 3; ++k) extent = std::max(extent, c.hi[k] - c.lo[k]);
        if (extent > 2 * tile)
            throw Error("a connected body of particles spans " + fmt(extent) + " world units on one axis, more than one lattice holds (" +
                        fmt(2 * tile) + "); use a larger cell or a larger radius");
        group_of_root[root] = extent <= tile ? GroupKey{0, std::int64_t(std::floor(c.lo[0] / tile)),
                                                        std::int64_t(std::floor(c.lo[1] / tile)), std::int64_t(std::floor(c.lo[2] / tile))}
                                             : GroupKey{1, root, 0, 0};
    }
    std::map<GroupKey, std::vector<std::uint32_t>> groups;  // ordered: deterministic group order
    for (std::size_t i = 0; i < n; ++i) groups[group_of_root[comp.find(cell[i])]].push_back(std::uint32_t(i));
    std::vector<std::vector<std::uint32_t>> out;
    out.reserve(groups.size());
    for (auto& [key, members] : groups) out.push_back(std::move(members));
    return out;
}

}  // namespace trilevel
