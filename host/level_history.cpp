// Level history between the frames of a sequence (level_history.hpp).
#include "level_history.hpp"

#include "core/lattice.hpp"

namespace trilevel {

std::uint8_t LevelHistory::previous(glm::ivec3 c, const CoarseBase& base) const {
    std::int64_t rel[3];
    for (int a = 0; a < 3; ++a) {
        rel[a] = std::int64_t(c[a]) + base[std::size_t(a)] - base_[std::size_t(a)];
        if (rel[a] < 0 || rel[a] > lattice::kMaxCoord) return 0;
    }
    return std::uint8_t(levels_.level(glm::ivec3(std::int32_t(rel[0]), std::int32_t(rel[1]), std::int32_t(rel[2]))));
}

std::vector<std::uint8_t> LevelHistory::previous_levels(const std::vector<CoarseCell>& cells,
                                                       const CoarseBase& base) const {
    std::vector<std::uint8_t> out;
    if (!valid_) return out;
    out.reserve(cells.size());
    for (const CoarseCell& c : cells) out.push_back(previous(c.coord, base));
    return out;
}

std::size_t LevelHistory::apply(std::vector<CoarseCell>& cells, const std::vector<float>& curvature,
                                const std::vector<std::uint8_t>& forced, const std::vector<std::uint8_t>& previous,
                                float threshold, float h) {
    if (previous.empty() || h <= 0.0f) return 0;
    const float stay3 = threshold * (1.0f - h), stay2 = threshold * (1.0f + h);
    std::size_t held = 0;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        if (forced[i] || previous[i] == 0) continue;
        const std::uint8_t level = previous[i] == 3 ? (curvature[i] >= stay3 ? 3 : 2) : (curvature[i] >= stay2 ? 3 : 2);
        held += level != cells[i].level ? 1 : 0;
        cells[i].level = level;
    }
    return held;
}

std::vector<float> LevelHistory::check_scale(const std::vector<std::uint8_t>& previous, float h) {
    std::vector<float> scale;
    if (previous.empty() || h <= 0.0f) return scale;
    scale.reserve(previous.size());
    for (std::uint8_t before : previous) scale.push_back(before == 3 ? 1.0f - h : before == 2 ? 1.0f + h : 1.0f);
    return scale;
}

LevelHistory::Flips LevelHistory::compare(const std::vector<CoarseCell>& cells, const CoarseBase& base) const {
    Flips f;
    if (!valid_) return f;
    for (const CoarseCell& c : cells) {
        const std::uint8_t before = previous(c.coord, base);
        if (before == 0) continue;
        ++f.compared;
        f.changed += before != c.level ? 1 : 0;
    }
    return f;
}

void LevelHistory::record(const std::vector<CoarseCell>& cells, const CoarseBase& base) {
    levels_ = CellIndex(cells);
    base_ = base;
    valid_ = true;
}

}  // namespace trilevel
