// The parameter table (trilevel/params_table.hpp) against what it describes: every field of
// Params has an entry, the CLI's --help shows each entry's help and default, and the CLI run
// without options reconstructs with Params{}'s values (the level hysteresis: the CLI's own).
// The Python side: python/tests/test_params.py.
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "cli_test_support.hpp"
#include "trilevel/io.hpp"
#include "trilevel/params_table.hpp"

using trilevel::test::CliResult;
using trilevel::test::run_cli;
using trilevel::test::slurp;
using trilevel::test::TempDir;

namespace {

/// The member names of `struct Params` as declared in include/trilevel/trilevel.hpp.
std::set<std::string> declared_params_fields() {
    const std::string header = slurp(std::string(TRILEVEL_SOURCE_DIR) + "/include/trilevel/trilevel.hpp");
    const auto begin = header.find("\nstruct Params {");
    REQUIRE(begin != std::string::npos);
    const auto end = header.find("\n};", begin);
    REQUIRE(end != std::string::npos);
    std::istringstream body(header.substr(begin, end - begin));
    // "    float cell = 1.0f;  /// ..." or "    std::optional<Box> clip_box;": a type, a name, maybe a default.
    const std::regex member(R"(^    [A-Za-z_][A-Za-z0-9_:<>]* ([a-z_][a-z0-9_]*)( = [^;]*)?;.*)");
    std::set<std::string> fields;
    std::smatch m;
    for (std::string line; std::getline(body, line);)
        if (std::regex_match(line, m, member)) fields.insert(m[1]);
    return fields;
}

}  // namespace

TEST_CASE("params table: every field of Params has one entry, names unique", "[params]") {
    const std::set<std::string> declared = declared_params_fields();
    CHECK(declared.size() == 16);  // the parse found them (a new field: add its entry, then this count)
    std::set<std::string> fields, clis, pythons;
    for (const auto& e : trilevel::param_table()) {
        INFO(e.field);
        CHECK(fields.insert(e.field).second);
        CHECK(clis.insert(e.cli).second);
        CHECK(pythons.insert(e.python).second);
        CHECK(e.read != nullptr);
        CHECK_FALSE(e.help.empty());
        CHECK(e.help.find('\n') == std::string::npos);
        CHECK(e.help.back() != '.');  // the front ends append the default after it
        CHECK(e.cli.find("--") != std::string::npos);
    }
    CHECK(fields == declared);
    CHECK(&trilevel::param_info("cell") == &trilevel::param_table()[2]);
    CHECK_THROWS_WITH(trilevel::param_info("colour"), "no parameter named 'colour' in the parameter table");
}

TEST_CASE("params table: values as the front ends write them", "[params]") {
    const trilevel::Params d;
    CHECK(trilevel::param_value_text(trilevel::param_info("kernel_radius").read(d)) == "4");
    CHECK(trilevel::param_value_text(trilevel::param_info("level2_tolerance").read(d)) == "0.32");
    CHECK(trilevel::param_value_text(trilevel::param_info("mode").read(d)) == "adaptive");
    CHECK(trilevel::param_value_text(trilevel::param_info("smooth").read(d)) == "off");
    CHECK(trilevel::param_value_text(trilevel::param_info("clip_box").read(d)).empty());
    trilevel::Params p;
    p.mode = trilevel::Mode::Uniform;
    p.normals = trilevel::NormalMode::Area;
    p.clip_box = trilevel::Box{{-1.5f, 0, 0}, {1, 2, 0.1f}};
    p.memory_limit_bytes = 1ull << 40;
    CHECK(trilevel::param_value_text(trilevel::param_info("mode").read(p)) == "uniform");
    CHECK(trilevel::param_value_text(trilevel::param_info("normals").read(p)) == "area");
    CHECK(trilevel::param_value_text(trilevel::param_info("clip_box").read(p)) == "-1.5,0,0,1,2,0.1");
    CHECK(trilevel::param_value_text(trilevel::param_info("memory_limit_bytes").read(p)) == "1099511627776");
    // The CLI's defaults: placeholders say what they stand for, switches and unset boxes show none.
    CHECK(trilevel::param_cli_default_text(trilevel::param_info("curvature_threshold")) == "calibrated");
    CHECK(trilevel::param_cli_default_text(trilevel::param_info("smooth_iterations")) ==
          std::to_string(trilevel::kDefaultSmoothIterations));
    CHECK(trilevel::param_cli_default_text(trilevel::param_info("level_hysteresis")) == "0.2");
    CHECK(trilevel::param_cli_default_text(trilevel::param_info("smooth")).empty());
    CHECK(trilevel::param_cli_default_text(trilevel::param_info("particle_box")).empty());
    CHECK(trilevel::param_cli_default_text(trilevel::param_info("particle_radius")).empty());
}

TEST_CASE("params table: `trilevel reconstruct --help` shows each entry's help and default", "[params][cli]") {
    TempDir tmp;
    const CliResult r = run_cli(tmp, "reconstruct --help");
    REQUIRE(r.code == 0);
    for (const auto& e : trilevel::param_table()) {
        INFO(e.field);
        const std::string long_flag = e.cli.substr(e.cli.find("--"));
        const auto at = r.out.find("  " + (e.cli.find(',') != std::string::npos ? e.cli.substr(0, e.cli.find(',')) + "," : "") +
                                   long_flag + " ");
        REQUIRE(at != std::string::npos);
        // The option's entry, up to the next option's; CLI11 puts the help of a long name on the next line.
        std::string line;
        for (char c : r.out.substr(at, r.out.find("\n  -", at) - at))
            if (!(c == ' ' || c == '\n') || (!line.empty() && line.back() != ' ')) line += c == '\n' ? ' ' : c;
        while (!line.empty() && line.back() == ' ') line.pop_back();
        INFO(line);
        CHECK(line.find(e.help) != std::string::npos);
        const std::string d = trilevel::param_cli_default_text(e);
        if (d.empty()) CHECK(line.find("(default") == std::string::npos);
        else CHECK(line.size() >= d.size() + 11);
        if (!d.empty()) CHECK(line.substr(line.size() - d.size() - 11) == "(default: " + d + ")");
        if (e.required) CHECK(line.find("REQUIRED") != std::string::npos);
    }
}

TEST_CASE("params table: the CLI without options reconstructs with Params{}'s values", "[params][cli]") {
    TempDir tmp;
    const std::string in = tmp.file("in.xyz"), out = tmp.file("out.ply"), stats = tmp.file("stats.json");
    trilevel::write_particles(in, trilevel::generate_scene("sphere", 0.05f));
    const CliResult r = run_cli(tmp, "reconstruct '" + in + "' -o '" + out + "' -r 0.05 -q --stats '" + stats + "'");
    INFO(r.err);
    REQUIRE(r.code == 0);
    trilevel::Params expected;
    expected.particle_radius = 0.05f;
    expected.level_hysteresis = std::stof(trilevel::param_info("level_hysteresis").cli_default);
    CHECK(expected.level_hysteresis == 0.2f);
    const auto got = nlohmann::json::parse(slurp(stats))["parameters"];
    CHECK(got == nlohmann::json::parse(trilevel::stats_to_json(trilevel::Stats{}, expected))["parameters"]);
    CHECK(got.size() == 15);  // every field but the memory limit, which stats do not report
}
