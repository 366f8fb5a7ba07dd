// Crack closing by collapse (docs/design.md §7); see crack_collapse.hpp.
#include "crack_collapse.hpp"

#include <glm/glm.hpp>

#include "edge_collapse.hpp"

namespace trilevel {

std::size_t collapse_crack_runs(Mesh& mesh, const CrackRuns& runs, std::vector<std::uint32_t>* kept) {
    std::vector<std::uint32_t> vertices;  // every vertex of every run
    for (std::size_t i = 0; i < runs.size(); i += runs[i] + 1)
        vertices.insert(vertices.end(), runs.begin() + std::ptrdiff_t(i) + 1, runs.begin() + std::ptrdiff_t(i + runs[i]) + 1);
    EdgeCollapser c(mesh, vertices);
    for (std::size_t i = 0; i < runs.size(); i += runs[i] + 1) {
        const std::uint32_t a = runs[i + 1], b = runs[i + runs[i]];
        // The inner chain is runs[front .. back); from the ends inwards, each step merges an end
        // vertex of it into the run end beside it, the nearer pair first (the smaller move of the surface).
        std::size_t front = i + 2, back = i + runs[i];
        auto merge_front = [&] { return c.collapse(runs[front], a) && (++front, true); };
        auto merge_back = [&] { return c.collapse(runs[back - 1], b) && (--back, true); };
        while (front < back) {
            const bool front_first = glm::distance(c.position(runs[front]), c.position(a)) <=
                                     glm::distance(c.position(runs[back - 1]), c.position(b));
            if (!(front_first ? merge_front() || merge_back() : merge_back() || merge_front())) break;
        }
    }
    const std::size_t collapsed = c.collapses();
    std::vector<std::uint32_t> left = c.compact();  // every vertex where none was collapsed
    if (kept) *kept = std::move(left);
    return collapsed;
}

}  // namespace trilevel
