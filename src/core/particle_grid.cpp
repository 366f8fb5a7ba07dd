// Particle grid of the host stages; see particle_grid.hpp.
#include "core/particle_grid.hpp"

#include <string>

#include "trilevel/trilevel.hpp"

namespace trilevel {

namespace {

constexpr int kMaxAxisCell = (1 << 21) - 1;  // 21 bits per axis in a sorted layout's key

}  // namespace

ParticleGrid::ParticleGrid(const float* xyz, std::size_t count, float cell, std::size_t dense_limit) : cell_(cell) {
    if (!(cell > 0.0f) || !std::isfinite(cell)) throw Error("particle grid: cell edge must be finite and > 0, got " + std::to_string(cell));
    if (count == 0) return;
    if (count > std::size_t(UINT32_MAX) - 1) throw Error("particle grid: too many particles");
    const auto at = [&](std::size_t j) { return glm::vec3(xyz[3 * j], xyz[3 * j + 1], xyz[3 * j + 2]); };
    lo_ = at(0);
    glm::vec3 hi = lo_;
    for (std::size_t j = 1; j < count; ++j) {
        lo_ = glm::min(lo_, at(j));
        hi = glm::max(hi, at(j));
    }
    // The cell of each particle, written as the reference grid writes it (float), clamped per axis.
    const auto cell_of = [&](glm::vec3 x) {
        const glm::vec3 c = glm::floor((x - lo_) / cell_);
        return glm::ivec3(glm::clamp(c, glm::vec3(0.0f), glm::vec3(float(kMaxAxisCell))));
    };
    dims_ = cell_of(hi) + 1;  // every rounding step is monotone: the largest coordinate has the last cell
    const double cells = double(dims_.x) * dims_.y * dims_.z;
    const double limit = std::min(dense_limit > 0 ? double(dense_limit) : std::max(4.0 * double(count), double(1 << 20)),
                                  double(UINT32_MAX - 1));  // dense cell indices are 32-bit
    ids_.resize(count);
    pos_.resize(count);
    if (cells <= limit) {
        // Counting sort by cell: cell order, then ascending index.
        std::vector<std::uint32_t> of(count);
        start_.assign(std::size_t(cells) + 1, 0);
        for (std::size_t j = 0; j < count; ++j) {
            const glm::ivec3 c = cell_of(at(j));
            of[j] = std::uint32_t((std::size_t(c.z) * std::size_t(dims_.y) + std::size_t(c.y)) * std::size_t(dims_.x) + std::size_t(c.x));
            ++start_[of[j] + 1];
        }
        for (std::size_t k = 1; k < start_.size(); ++k) start_[k] += start_[k - 1];
        for (std::size_t j = 0; j < count; ++j) {  // fills each cell from its end backwards: j descending
            const std::size_t j2 = count - 1 - j;
            const std::uint32_t s = --start_[of[j2] + 1];
            ids_[s] = std::uint32_t(j2);
            pos_[s] = at(j2);
        }
        // start_[k + 1] now holds the first slot of cell k; shift back by one.
        for (std::size_t k = 0; k + 1 < start_.size(); ++k) start_[k] = start_[k + 1];
        start_.back() = std::uint32_t(count);
        return;
    }
    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(count);
    for (std::size_t j = 0; j < count; ++j) {
        const glm::ivec3 c = cell_of(at(j));
        keyed[j] = {key(c.x, c.y, c.z), std::uint32_t(j)};
    }
    std::sort(keyed.begin(), keyed.end());
    for (std::size_t s = 0; s < count; ++s) {
        ids_[s] = keyed[s].second;
        pos_[s] = at(keyed[s].second);
        if (s == 0 || keyed[s].first != keyed[s - 1].first) {
            keys_.push_back(keyed[s].first);
            key_start_.push_back(std::uint32_t(s));
        }
    }
    key_start_.push_back(std::uint32_t(count));
}

}  // namespace trilevel
