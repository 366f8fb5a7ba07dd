// Triangles in a uniform grid; see triangle_grid.hpp.
#include "triangle_grid.hpp"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace trilevel {

TriangleGrid::TriangleGrid(const Mesh& mesh, const std::vector<std::uint8_t>& dead) {
    const std::uint32_t nt = std::uint32_t(mesh.triangle_count());
    relisted_.assign(nt, 0);
    // Boxes in floats: they hold the float positions' bounds exactly. Taken again in each pass
    // below rather than kept (two more arrays as large as the entries').
    const float* x = mesh.positions.data();
    auto box = [&](std::uint32_t t, glm::vec3& lo, glm::vec3& hi) {
        const std::uint32_t* c = mesh.triangles.data() + 3 * std::size_t(t);
        const glm::vec3 p0(x[3 * c[0]], x[3 * c[0] + 1], x[3 * c[0] + 2]), p1(x[3 * c[1]], x[3 * c[1] + 1], x[3 * c[1] + 2]),
            p2(x[3 * c[2]], x[3 * c[2] + 1], x[3 * c[2] + 2]);
        lo = glm::min(p0, glm::min(p1, p2));
        hi = glm::max(p0, glm::max(p1, p2));
    };
    struct Bounds {
        glm::vec3 low{INFINITY}, high{-INFINITY};
        float extent = 0.0f;
    };
    const Bounds all = tbb::parallel_reduce(
        tbb::blocked_range<std::uint32_t>(0, nt, 8192), Bounds{},
        [&](const auto& range, Bounds b) {
            glm::vec3 lo, hi;
            for (std::uint32_t t = range.begin(); t != range.end(); ++t) {
                if (dead[t]) continue;
                box(t, lo, hi);
                const glm::vec3 d = hi - lo;
                b.low = glm::min(b.low, lo);
                b.high = glm::max(b.high, hi);
                b.extent = std::max(b.extent, std::max(d.x, std::max(d.y, d.z)));
            }
            return b;
        },
        [](const Bounds& a, const Bounds& b) { return Bounds{glm::min(a.low, b.low), glm::max(a.high, b.high), std::max(a.extent, b.extent)}; });
    const glm::vec3 low = all.high.x >= all.low.x ? all.low : glm::vec3(0.0f), high = all.high.x >= all.low.x ? all.high : glm::vec3(0.0f);
    const float extent = all.extent;
    // Cells of the largest extent, grown by factors of 1.5 (three at most) while the grid over the
    // mesh's box would have more than max(2 triangles, 2^20) cells; where it still would, its
    // longest axis is halved until it has no more: the grid wraps around along the axes it does
    // not span (see the header). A frame's mesh needs at most a growth or two (x64: 2.25 times
    // the largest triangle, whose queries then read fewer cells than wrapped ones). With 4 cells a
    // triangle, x64's mesh 4% larger stopped at 1.5 times: 2.9 M cells, 8 MB more at the run's peak.
    origin_ = glm::dvec3(low);
    reach_ = double(extent);
    cell_ = extent > 0.0f && std::isfinite(extent) ? double(extent) : 1.0;
    const glm::dvec3 size = glm::dvec3(high) - origin_;
    const double limit = std::max(2.0 * double(nt), double(1 << 20));
    auto cells = [&](double side) { return glm::min(glm::floor(size / side) + 1.0, glm::dvec3(double(1 << 30))); };
    auto count_of = [](glm::dvec3 d) { return d.x * d.y * d.z; };
    for (int growth = 0; growth < 3 && count_of(cells(cell_)) > limit; ++growth) cell_ *= 1.5;
    glm::dvec3 dims = cells(cell_);
    while (count_of(dims) > limit) {
        const int a = dims.x >= dims.y && dims.x >= dims.z ? 0 : dims.y >= dims.z ? 1 : 2;
        dims[a] = std::ceil(dims[a] / 2.0);
    }
    dims_ = glm::ivec3(dims);
    const std::size_t count = std::size_t(dims_.x) * std::size_t(dims_.y) * std::size_t(dims_.z);

    // Counting sort by cell; the triangles' order within a cell is theirs.
    std::vector<std::uint32_t> of(nt);
    tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, nt, 8192), [&](const auto& range) {
        glm::vec3 lo, hi;
        for (std::uint32_t t = range.begin(); t != range.end(); ++t) {
            if (dead[t]) continue;
            box(t, lo, hi);
            const glm::ivec3 k = cell(lo);
            of[t] = std::uint32_t(index(k.x, k.y, k.z));
        }
    });
    // start_[c + 1] counts cell c, is scanned into cell c's first entry and advanced over its
    // entries while they are placed, which leaves it at cell c + 1's first: no second array of a
    // word a cell (10 MB at x64) for the fill positions.
    start_.assign(count + 1, 0);
    for (std::uint32_t t = 0; t < nt; ++t)
        if (!dead[t]) ++start_[of[t] + 1];
    std::uint32_t total = 0;
    for (std::size_t c = 0; c < count; ++c) {  // start_[c + 1]: cell c's first entry
        const std::uint32_t n = start_[c + 1];
        start_[c + 1] = total;
        total += n;
    }
    entry_.resize(total);
    entry_lo_.resize(total);
    entry_hi_.resize(total);
    for (std::uint32_t t = 0; t < nt; ++t) {
        if (dead[t]) continue;
        const std::uint32_t i = start_[of[t] + 1]++;
        entry_[i] = t;
        box(t, entry_lo_[i], entry_hi_[i]);
    }
    moved_in_row_.assign(std::size_t(dims_.y) * std::size_t(dims_.z), 0);
}

glm::i64vec3 TriangleGrid::raw_cell(glm::dvec3 p) const {
    constexpr double kFar = double(std::int64_t(1) << 40);  // beyond any mesh's extent in cells
    return glm::i64vec3(glm::clamp(glm::floor((p - origin_) / cell_), glm::dvec3(-kFar), glm::dvec3(kFar)));
}

glm::ivec3 TriangleGrid::wrap(glm::i64vec3 c) const {
    const glm::i64vec3 d(dims_);
    return glm::ivec3(((c % d) + d) % d);
}

void TriangleGrid::push(Local& list, std::uint32_t t, std::size_t c, glm::vec3 lo, glm::vec3 hi) {
    list.tri_.push_back(t);
    list.cell_.push_back(std::uint32_t(c));
    list.lo_.push_back(lo);
    list.hi_.push_back(hi);
    list.next_.push_back(list.head(c));
    list.set_head(c, std::uint32_t(list.tri_.size() - 1));
}

void TriangleGrid::relist_in_grid(std::uint32_t t, std::size_t c, glm::vec3 lo, glm::vec3 hi) {
    push(moved_, t, c, lo, hi);
    ++moved_in_row_[c / std::size_t(dims_.x)];
}

void TriangleGrid::relist(std::uint32_t t, glm::dvec3 lo, glm::dvec3 hi, Local* local) {
    const glm::ivec3 k = cell(lo);
    const std::size_t c = index(k.x, k.y, k.z);
    relisted_[t] = 1;
    const glm::vec3 lof(lo), hif(hi);  // float corners: their box is exact in floats
    if (!local) {
        relist_in_grid(t, c, lof, hif);
        const glm::dvec3 d = hi - lo;
        reach_ = std::max(reach_, std::max(d.x, std::max(d.y, d.z)));
        return;
    }
    // A Local's triangles must keep within reach(): queries of other threads use it unchanged.
    push(*local, t, c, lof, hif);
}

void TriangleGrid::Local::set_head(std::size_t cell, std::uint32_t entry) {
    if (2 * (used_ + 1) > cells_.size()) {  // grow: the slots again at twice the size
        std::vector<std::uint32_t> old_cells = std::move(cells_), old_heads = std::move(heads_);
        cells_.assign(std::max<std::size_t>(1024, 2 * old_cells.size()), 0);
        heads_.resize(cells_.size());
        used_ = 0;
        for (std::size_t s = 0; s < old_cells.size(); ++s)
            if (old_cells[s] != 0) set_head(old_cells[s] - 1, old_heads[s]);
    }
    std::size_t s = slot_of(cell);
    while (cells_[s] != 0 && cells_[s] != cell + 1) s = (s + 1) & (cells_.size() - 1);
    if (cells_[s] == 0) {
        cells_[s] = std::uint32_t(cell + 1);
        ++used_;
    }
    heads_[s] = entry;
}

void TriangleGrid::adopt(Local& local) {
    for (std::size_t k = 0; k < local.tri_.size(); ++k) relist_in_grid(local.tri_[k], local.cell_[k], local.lo_[k], local.hi_[k]);
    std::fill(local.cells_.begin(), local.cells_.end(), 0u);  // left clean for its next region
    local.used_ = 0;
    local.tri_.clear();
    local.next_.clear();
    local.cell_.clear();
    local.lo_.clear();
    local.hi_.clear();
}

}  // namespace trilevel
