// The particles binned into cubic cells: the one neighbour search of the host stages that read the
// particles after the mesh is built (smoothing weights, gradient normals, attributes), built once
// per frame (src/reconstructor.cpp). Each stage filters the candidates with its own distance test.
//
// Visit order: ascending (cell z, cell y, cell x, particle index), the same for every query and
// thread count, so sums over the neighbours are deterministic (a search that may stop early
// visits the rows nearest first instead, for_each_candidate). It is also the order of the plain
// C++ reference's hash grid (src/reference/) for the same cell edge, which the vertex stages used
// before: their outputs keep their bits.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <vector>

#include <glm/glm.hpp>

namespace trilevel {

class ParticleGrid {
public:
    /// xyz: `count` particles as x, y, z floats (world units); copied, not kept. cell: the cell edge
    /// in world units (finite, > 0; Error otherwise). A particle's cell is floor((x - lo) / cell)
    /// evaluated in float, lo the particles' componentwise minimum. The cells' particle ranges are
    /// a dense table while the particles' box holds at most max(4 count, 2^20) cells (about 4 bytes
    /// per particle), else sorted cell keys searched per row; `dense_limit` > 0 replaces that bound
    /// (tests reach the sorted layout with it).
    ParticleGrid(const float* xyz, std::size_t count, float cell, std::size_t dense_limit = 0);

    /// Calls f(j, x_j) for every particle j in the cells that can hold a particle within `radius`
    /// (world units, >= 0) of p: all of those, and others (callers filter by their own distance
    /// test). Each row of cells along x is cut to the ball's extent at its distance from p in y
    /// and z. Cell bounds are widened by the float rounding of the particles' cell coordinates, so
    /// no particle within `radius` is missed at any distance from the origin. Order: see above.
    /// A callback that returns bool stops the search by returning true; such a search visits the
    /// rows nearest first (z rows outwards from p's, in each the y rows likewise, the particles of
    /// a row in (x, index) order), so that a partial sum near p is reached early.
    template <class F>
    void for_each_candidate(glm::vec3 p, double radius, F&& f) const {
        if (ids_.empty()) return;
        // In cell units: t = p's coordinate, span = radius. A particle's computed coordinate is its
        // exact one times (1 +- 2^-23) (two float roundings); `slack` covers that many times over.
        double t[3], slack[3];
        int lo[3], hi[3];
        const double span = radius / double(cell_);
        for (int a = 0; a < 3; ++a) {
            t[a] = (double(p[a]) - double(lo_[a])) / double(cell_);
            slack[a] = (std::fabs(t[a]) + span + 1.0) * 0x1p-16;
            if (!window(t[a], span, slack[a], dims_[a], lo[a], hi[a])) return;  // also for NaN p
        }
        const double span2 = span * span * (1.0 + 0x1p-30);  // rounds up: never cuts a particle off
        constexpr bool stops = std::is_same_v<std::invoke_result_t<F&, std::uint32_t, glm::vec3>, bool>;
        // Rows lo..hi in visit order: ascending, or outwards from the one holding t (stopping).
        auto rows = [&](double t, int lo, int hi, auto&& visit) {
            if constexpr (!stops) {
                for (int c = lo; c <= hi; ++c)
                    if (visit(c)) return true;
            } else {
                const int centre = int(std::clamp(std::floor(t), double(lo), double(hi)));
                for (int d = 0; centre - d >= lo || centre + d <= hi; ++d) {
                    if (centre - d >= lo && visit(centre - d)) return true;
                    if (d > 0 && centre + d <= hi && visit(centre + d)) return true;
                }
            }
            return false;
        };
        rows(t[2], lo[2], hi[2], [&](int z) {
            const double gz = gap(t[2], z, slack[2]), rz2 = span2 - gz * gz;
            if (rz2 < 0.0) return false;
            return rows(t[1], lo[1], hi[1], [&](int y) {
                const double gy = gap(t[1], y, slack[1]), ry2 = rz2 - gy * gy;
                int x0, x1;
                if (ry2 < 0.0 || !window(t[0], std::sqrt(ry2) * (1.0 + 0x1p-30), slack[0], dims_[0], x0, x1)) return false;
                const auto [b, e] = row(z, y, x0, x1);
                for (std::uint32_t s = b; s < e; ++s) {
                    if constexpr (stops) {
                        if (f(ids_[s], pos_[s])) return true;
                    } else {
                        f(ids_[s], pos_[s]);
                    }
                }
                return false;
            });
        });
    }

    float cell() const { return cell_; }
    std::size_t size() const { return ids_.size(); }
    bool dense() const { return !start_.empty(); }

private:
    /// Cells c0..c1 (clamped to 0..dims - 1) that can hold coordinates in t +- (half + slack);
    /// false where none can.
    static bool window(double t, double half, double slack, int dims, int& c0, int& c1) {
        const double a0 = std::floor(t - half - slack), a1 = std::floor(t + half + slack);
        if (!(a1 >= 0.0) || !(a0 <= double(dims - 1))) return false;
        c0 = int(std::max(a0, 0.0));
        c1 = int(std::min(a1, double(dims - 1)));
        return true;
    }
    /// Distance in cell units from t to the widened cell [c - slack, c + 1 + slack]; rounds down.
    static double gap(double t, int c, double slack) {
        const double below = double(c) - slack - t, above = t - (double(c) + 1.0 + slack);
        return std::max(std::max(below, above), 0.0) * (1.0 - 0x1p-30);
    }

    /// Particle slots [b, e) of the cells (x0..x1, y, z): one contiguous range, in (x, index) order.
    std::pair<std::uint32_t, std::uint32_t> row(int z, int y, int x0, int x1) const {
        if (dense()) {
            const std::size_t k = (std::size_t(z) * std::size_t(dims_[1]) + std::size_t(y)) * std::size_t(dims_[0]);
            return {start_[k + std::size_t(x0)], start_[k + std::size_t(x1) + 1]};
        }
        const auto b = std::lower_bound(keys_.begin(), keys_.end(), key(x0, y, z));
        const auto e = std::lower_bound(b, keys_.end(), key(x1, y, z) + 1);
        return {key_start_[std::size_t(b - keys_.begin())], key_start_[std::size_t(e - keys_.begin())]};
    }
    static std::uint64_t key(int x, int y, int z) {
        return std::uint64_t(x) | (std::uint64_t(y) << 21) | (std::uint64_t(z) << 42);
    }

    float cell_;
    glm::vec3 lo_{0.0f};
    glm::ivec3 dims_{0};                  ///< cells per axis (coordinates clamped to 2^21 - 1)
    std::vector<std::uint32_t> start_;    ///< dense: cell k holds slots start_[k] .. start_[k + 1]
    std::vector<std::uint64_t> keys_;     ///< sorted: the occupied cells' keys, ascending
    std::vector<std::uint32_t> key_start_;///< sorted: keys_[i] holds slots key_start_[i] .. [i + 1]
    std::vector<std::uint32_t> ids_;      ///< particle index per slot
    std::vector<glm::vec3> pos_;          ///< particle position per slot
};

}  // namespace trilevel
