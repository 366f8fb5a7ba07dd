// Crack closing by collapse (docs/design.md §7); see crack_collapse.hpp.
#include "crack_collapse.hpp"

#include <algorithm>
#include <cmath>

#include <glm/glm.hpp>

#include "edge_collapse.hpp"

namespace trilevel {

namespace {

/// Where one run stands: its inner chain is runs[front .. back).
struct RunState {
    std::size_t first = 0, front = 0, back = 0;
};

/// Where the two pairs of a run differ in length by less than this fraction, the front goes
/// first. Symmetric runs (an inner vertex halfway between the ends) are common on the lattice, and
/// the float rounding of the positions decides such a tie: 1e5 r from the origin it moves them by
/// up to 0.4% of r, which chose the other end there and gave another mesh.
constexpr double kPairTie = 0.01;

/// Collapses a run's inner vertices from the ends inwards, each into the run end beside it, the
/// clearly nearer pair first (the smaller move of the surface; kPairTie), until none is left or
/// neither end can go. Returns false where a collapse had to wait for the serial pass (a region's
/// worker only): the run stops there, and `s` says where to go on.
bool collapse_run(EdgeCollapser& c, const CrackRuns& runs, RunState& s, EdgeCollapser::Worker& w) {
    using Outcome = EdgeCollapser::Outcome;
    const std::uint32_t a = runs[s.first + 1], b = runs[s.first + runs[s.first]];
    while (s.front < s.back) {
        const bool front_first = glm::distance(c.position(runs[s.front]), c.position(a)) <=
                                 (1.0 + kPairTie) * glm::distance(c.position(runs[s.back - 1]), c.position(b));
        bool merged = false;
        for (int k = 0; k < 2 && !merged; ++k) {
            const bool front = (k == 0) == front_first;
            const Outcome o = front ? c.collapse(runs[s.front], a, w) : c.collapse(runs[s.back - 1], b, w);
            if (o == Outcome::Deferred) return false;
            if (o == Outcome::Collapsed) {
                merged = true;
                front ? ++s.front : --s.back;
            }
        }
        if (!merged) break;
    }
    return true;
}

}  // namespace

std::size_t collapse_crack_runs(Mesh& mesh, const CrackRuns& runs, std::vector<std::uint32_t>* kept) {
    std::vector<std::uint32_t> vertices;  // every vertex of every run
    std::vector<RunState> states;
    for (std::size_t i = 0; i < runs.size(); i += runs[i] + 1) {
        vertices.insert(vertices.end(), runs.begin() + std::ptrdiff_t(i) + 1, runs.begin() + std::ptrdiff_t(i + runs[i]) + 1);
        states.push_back({i, i + 2, i + runs[i]});
    }
    EdgeCollapser c(mesh, vertices);
    if (!states.empty()) {
        // Whole runs on all threads (EdgeCollapser::in_tiles), each in the tile of its first end:
        // a collapse reads within 3 and writes within 2 interaction reaches of its vertex
        // (edge_collapse.hpp), and a run's vertices lie within `extent` of its first end along
        // every axis, so tiles 2 extent + 6 reaches wide keep runs of one phase apart. A run whose
        // collapse would grow a triangle beyond the bound goes on afterwards, in run order.
        c.prepare_parallel(1.5);
        double extent = 0.0;
        for (const RunState& s : states)
            for (std::size_t k = 2; k <= runs[s.first]; ++k) {
                const glm::dvec3 d = glm::abs(c.position(runs[s.first + k]) - c.position(runs[s.first + 1]));
                extent = std::max({extent, d.x, d.y, d.z});
            }
        const double width = 2.0 * extent + 6.0 * c.interaction_reach();
        const std::vector<std::uint8_t> deferred = c.in_tiles(
            states.size(), width, [&](std::uint32_t r) { return c.position(runs[states[r].first + 1]); },
            [&](std::uint32_t r, EdgeCollapser::Worker& w) { return collapse_run(c, runs, states[r], w); });
        EdgeCollapser::Worker serial;
        for (std::uint32_t r = 0; r < states.size(); ++r)
            if (deferred[r]) collapse_run(c, runs, states[r], serial);
    }
    const std::size_t collapsed = c.collapses();
    std::vector<std::uint32_t> left = c.compact();  // every vertex where none was collapsed
    if (kept) *kept = std::move(left);
    return collapsed;
}

}  // namespace trilevel
