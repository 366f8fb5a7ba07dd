// Helpers of the [mesh] tests: fields on blocks of coarse cells, closed-mesh checks.
#pragma once

#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "coarse_cells.hpp"
#include "fine_point_map.hpp"
#include "mesh_topology.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel::test {

/// Cells of a dims^3 block at `offset` (coarse coordinates), sorted by lattice::pack, all `level`.
inline std::vector<CoarseCell> block_cells(glm::ivec3 dims, glm::ivec3 offset, std::uint8_t level) {
    std::vector<CoarseCell> cells;
    for (int z = 0; z < dims.z; ++z)
        for (int y = 0; y < dims.y; ++y)
            for (int x = 0; x < dims.x; ++x) cells.push_back({offset + glm::ivec3(x, y, z), level});
    return cells;  // x fastest: increasing pack order
}

/// A map holding every point of every cell at its stride, valued by `f(p)`.
inline FinePointMap make_field(const std::vector<CoarseCell>& cells, const LatticeFrame& frame,
                               const std::function<float(glm::ivec3)>& f) {
    const int cs = frame.coarse_steps;
    const std::size_t per_cell = std::size_t(cs + 1) * (cs + 1) * (cs + 1);
    FinePointMap map(2 * per_cell * cells.size());
    for (const CoarseCell& c : cells) {
        const int st = stride(c.level);
        for (int z = 0; z <= cs; z += st)
            for (int y = 0; y <= cs; y += st)
                for (int x = 0; x <= cs; x += st) {
                    const glm::ivec3 p = c.coord * cs + glm::ivec3(x, y, z);
                    if (!map.find(p)) map.insert(lattice::pack(p), f(p));
                }
    }
    return map;
}

/// Does p lie on the boundary of the box of lattice points [lo, hi]?
inline bool on_box_boundary(glm::ivec3 p, glm::ivec3 lo, glm::ivec3 hi) {
    return glm::any(glm::equal(p, lo)) || glm::any(glm::equal(p, hi));
}

inline double signed_volume(const Mesh& m) {
    double v = 0.0;
    for (std::size_t t = 0; t < m.triangle_count(); ++t) {
        const float* a = &m.positions[3 * m.triangles[3 * t]];
        const float* b = &m.positions[3 * m.triangles[3 * t + 1]];
        const float* c = &m.positions[3 * m.triangles[3 * t + 2]];
        v += (double(a[0]) * (double(b[1]) * c[2] - double(b[2]) * c[1]) -
              double(a[1]) * (double(b[0]) * c[2] - double(b[2]) * c[0]) +
              double(a[2]) * (double(b[0]) * c[1] - double(b[1]) * c[0])) / 6.0;
    }
    return v;
}

/// A non-empty mesh, closed and consistently oriented, counter-clockwise seen from outside.
inline void require_closed(const Mesh& m, const std::string& what) {
    INFO(what << ": " << m.triangle_count() << " triangles");
    REQUIRE(m.triangle_count() > 0);
    const MeshTopologyReport t = mesh_topology_report(m);
    CHECK(t.boundary_edges == 0);
    CHECK(t.non_manifold_edges == 0);
    CHECK(t.orientation_conflicts == 0);
    REQUIRE(is_closed_and_oriented(m));
    REQUIRE(signed_volume(m) > 0);  // oriented outwards
}

}  // namespace trilevel::test
