// Statistics as JSON (docs/operations.md "Statistics"; docs/design.md §10).
#include <nlohmann/json.hpp>

#include "trilevel/trilevel.hpp"

namespace trilevel {

std::string stats_to_json(const Stats& s, const Params& p) {
    nlohmann::ordered_json j;
    j["particles"] = s.particles;
    j["surface_particles"] = s.surface_particles;
    j["splash_particles"] = s.splash_particles;
    j["surface_cells"] = s.surface_cells;
    j["surface_cells_by_level"] = {{"2", s.surface_cells_level2}, {"3", s.surface_cells_level3}};
    j["splash_cells"] = s.splash_cells;
    j["isolated_piece_cells"] = s.isolated_piece_cells;
    j["band_closure_cells"] = s.band_closure_cells;
    j["level2_check_cells"] = s.level2_check_cells;
    j["fine_points"] = s.fine_points;
    j["fine_points_by_level"] = {{"2", s.fine_points_level2}, {"3", s.fine_points_level3}};
    j["vertices"] = s.vertices;
    j["triangles"] = s.triangles;
    j["triangles_by_kind"] = {{"level2", s.triangles_level2}, {"level3", s.triangles_level3}, {"patch", s.triangles_patch}};
    j["crack_vertices_collapsed"] = s.crack_vertices_collapsed;
    j["particles_outside_box"] = s.particles_outside_box;
    j["components_removed"] = s.components_removed;
    j["clip_cap_triangles"] = s.clip_cap_triangles;
    if (p.smooth || p.sliver_cleanup) {
        j["sliver_edges_collapsed"] = s.sliver_edges_collapsed;
        j["smoothing_reverted_moves"] = s.smoothing_reverted_moves;
    }
    nlohmann::ordered_json t = nlohmann::ordered_json::object();
    for (const auto& [name, ms] : s.time_ms) t[name] = ms;
    j["time_ms"] = t;
    nlohmann::ordered_json k = nlohmann::ordered_json::object();
    for (const auto& [name, ms] : s.kernel_ms) k[name] = ms;
    j["kernel_ms"] = k;
    j["peak_memory_bytes"] = s.peak_memory_bytes;
    j["device_memory_bytes"] = s.device_memory_bytes;
    j["closed"] = s.closed;
    if (s.level_history)
        j["level_flips"] = {{"changed", s.level_flips},
                            {"compared", s.level_cells_compared},
                            {"share", s.level_cells_compared ? double(s.level_flips) / double(s.level_cells_compared) : 0.0},
                            {"held_by_hysteresis", s.level_held}};
    j["device"] = s.device;
    j["threads"] = {{"host", s.host_threads}, {"device_compute_units", s.device_compute_units}};
    j["parameters"] = {{"particle_radius", p.particle_radius},
                       {"kernel_radius", p.kernel_radius},
                       {"mode", p.mode == Mode::Adaptive ? "adaptive" : "uniform"},
                       {"cell", p.cell},
                       {"normals", p.normals == NormalMode::Gradient ? "gradient" : p.normals == NormalMode::Area ? "area" : "none"},
                       {"curvature_threshold", p.curvature_threshold > 0 ? p.curvature_threshold : default_curvature_threshold()},
                       {"level2_tolerance", p.level2_tolerance},
                       {"crack_closing", p.crack_closing == CrackClosing::Collapse ? "collapse" : "patches"},
                       {"level_hysteresis", p.level_hysteresis},
                       {"remove_components_below", p.remove_components_below},
                       {"smooth", p.smooth},
                       {"smooth_iterations", p.smooth ? (p.smooth_iterations > 0 ? p.smooth_iterations : kDefaultSmoothIterations) : 0},
                       {"sliver_cleanup", p.smooth || p.sliver_cleanup}};
    auto box = [](const Box& b) {
        return nlohmann::ordered_json{{"min", {b.min[0], b.min[1], b.min[2]}}, {"max", {b.max[0], b.max[1], b.max[2]}}};
    };
    j["parameters"]["particle_box"] = p.particle_box ? box(*p.particle_box) : nlohmann::ordered_json(nullptr);
    j["parameters"]["clip_box"] = p.clip_box ? box(*p.clip_box) : nlohmann::ordered_json(nullptr);
    return j.dump(2) + "\n";
}

}  // namespace trilevel
