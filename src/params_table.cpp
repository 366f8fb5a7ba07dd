// The table of Params fields that the CLI and the Python module build their options, defaults and
// help from (trilevel/params_table.hpp).
#include "trilevel/params_table.hpp"

#include <charconv>

namespace trilevel {

namespace {

ParamValue box_value(const std::optional<Box>& box) {
    if (!box) return std::monostate{};
    std::string text;
    for (int k = 0; k < 6; ++k) {
        if (k) text += ',';
        text += param_value_text(k < 3 ? box->min[k] : box->max[k - 3]);
    }
    return text;
}

std::vector<ParamInfo> make_table() {
    std::vector<ParamInfo> t;
    auto add = [&t](std::string field, std::string cli, std::string python, std::string help, ParamValue (*read)(const Params&)) -> ParamInfo& {
        ParamInfo& e = t.emplace_back();
        e.field = std::move(field);
        e.cli = std::move(cli);
        e.python = std::move(python);
        e.help = std::move(help);
        e.read = read;
        return e;
    };
    add("particle_radius", "-r,--radius", "particle_radius",
        "Particle radius r in world units (half the rest spacing), > 0",
        [](const Params& p) -> ParamValue { return p.particle_radius; })
        .required = true;
    add("mode", "--mode", "mode",
        "'adaptive' (3-level grid: cells of 2r on flat water, r on curved and splashing water) or 'uniform' "
        "(one cell size everywhere)",
        [](const Params& p) -> ParamValue { return std::string(p.mode == Mode::Adaptive ? "adaptive" : "uniform"); });
    add("cell", "--cell", "cell", "Uniform mode: marching-cubes cell size in r: 4/n for an even n up to 64 (e.g. 2, 1, 0.5 or 0.25)",
        [](const Params& p) -> ParamValue { return p.cell; });
    add("kernel_radius", "--kernel-radius", "kernel_radius", "SPH kernel support R in multiples of r, in [1, 16]",
        [](const Params& p) -> ParamValue { return p.kernel_radius; });
    add("curvature_threshold", "--curvature-threshold", "curvature_threshold",
        "Adaptive mode: mean cell curvature (paper eq. 3) from which a coarse cell is meshed with cells of r",
        [](const Params& p) -> ParamValue { return p.curvature_threshold; })
        .default_means = "calibrated";
    add("level2_tolerance", "--level2-tolerance", "level2_tolerance",
        "Adaptive mode: also mesh with cells of r where the level-2 lattice misses the field at a cube centre by "
        "more than this many r, in cells whose curvature is not clearly flat; 0 = off",
        [](const Params& p) -> ParamValue { return p.level2_tolerance; });
    add("memory_limit_bytes", "--memory-limit", "memory_limit",
        "Budget in bytes for the largest allocations (a sequence: each frame's, less the next frame read ahead "
        "and the previous mesh being written)",
        [](const Params& p) -> ParamValue { return p.memory_limit_bytes; })
        .default_means = "the device's and host's limits";
    add("level_hysteresis", "--level-hysteresis", "level_hysteresis",
        "Adaptive mode, frame sequences: a cell keeps its previous frame's level until its curvature passes the "
        "threshold by this fraction of it, and the level-2 check's tolerance is held the same way; in [0, 1), 0 = off",
        [](const Params& p) -> ParamValue { return p.level_hysteresis; })
        .cli_default = "0.2";
    add("crack_closing", "--crack-closing", "crack_closing",
        "Adaptive mode: 'collapse' (inner crack crossings merged into the level-2 ones, two triangles fewer each) "
        "or 'patches' (every crack triangulated, paper 3.3.2)",
        [](const Params& p) -> ParamValue {
            return std::string(p.crack_closing == CrackClosing::Collapse ? "collapse" : "patches");
        });
    add("remove_components_below", "--remove-components-below", "remove_components_below",
        "Drop the connected parts of the mesh that enclose less than N particle volumes, N (2r)^3 (small droplets "
        "and cavities); 0 = off",
        [](const Params& p) -> ParamValue { return p.remove_components_below; });
    add("particle_box", "--particle-box", "particle_box",
        "Box x0,y0,z0,x1,y1,z1 (world units): the particles outside it are ignored, with their attributes "
        "(bounds inclusive)",
        [](const Params& p) { return box_value(p.particle_box); });
    add("clip_box", "--clip-box", "clip_box",
        "Box x0,y0,z0,x1,y1,z1 (world units): the surface is cut there and closed with flat caps, so the mesh stays "
        "closed with every vertex in the box; a box without fluid gives an empty mesh",
        [](const Params& p) { return box_value(p.clip_box); });
    add("smooth", "--smooth", "smooth",
        "Smooth the mesh for rendering: particle-weighted Laplacian smoothing that keeps each component's volume, "
        "with sliver cleanup; gradient normals become the smoothed mesh's area-weighted ones",
        [](const Params& p) -> ParamValue { return p.smooth; });
    add("smooth_iterations", "--smooth-iterations", "smooth_iterations",
        "Smoothing strength: its Laplacian steps, 1 to 1000 (the CLI option turns smoothing on)",
        [](const Params& p) -> ParamValue { return p.smooth_iterations; })
        .default_means = std::to_string(kDefaultSmoothIterations);
    add("sliver_cleanup", "--sliver-cleanup", "sliver_cleanup",
        "Collapse the needle triangles of marching cubes by index, keeping the mesh closed (on with smoothing)",
        [](const Params& p) -> ParamValue { return p.sliver_cleanup; });
    add("normals", "--normals", "normals",
        "Per-vertex normals: 'gradient' (of the scalar field: the smooth surface's normal; area-weighted on a "
        "smoothed mesh) or 'area' (area-weighted triangle normals)",
        [](const Params& p) -> ParamValue {
            if (p.normals == NormalMode::None) return std::monostate{};
            return std::string(p.normals == NormalMode::Gradient ? "gradient" : "area");
        });
    return t;
}

}  // namespace

const std::vector<ParamInfo>& param_table() {
    static const std::vector<ParamInfo> table = make_table();
    return table;
}

const ParamInfo& param_info(std::string_view field) {
    for (const auto& e : param_table())
        if (e.field == field) return e;
    throw Error("no parameter named '" + std::string(field) + "' in the parameter table");
}

std::string param_value_text(const ParamValue& v) {
    struct Text {
        std::string operator()(std::monostate) const { return ""; }
        std::string operator()(bool b) const { return b ? "on" : "off"; }
        std::string operator()(int i) const { return std::to_string(i); }
        std::string operator()(std::uint64_t u) const { return std::to_string(u); }
        std::string operator()(float f) const {
            char buf[32];
            const auto r = std::to_chars(buf, buf + sizeof buf, f);  // shortest text that reads back as f
            return std::string(buf, r.ptr);
        }
        std::string operator()(const std::string& s) const { return s; }
    };
    return std::visit(Text{}, v);
}

std::string param_cli_default_text(const ParamInfo& info) {
    if (info.required) return "";
    if (!info.default_means.empty()) return info.default_means;
    if (!info.cli_default.empty()) return info.cli_default;
    const ParamValue v = info.read(Params{});
    if (std::holds_alternative<bool>(v)) return "";  // a switch: off unless given
    return param_value_text(v);
}

}  // namespace trilevel
