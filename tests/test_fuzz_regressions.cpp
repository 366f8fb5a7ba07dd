// Inputs that once crashed a reader under the fuzz targets (fuzz/), kept in
// tests/data/fuzz_regressions/{particles,mesh}/ with the message each must now be rejected with
// (listed in EXPECTED there): every one must be a clean one-line trilevel::Error naming the file.
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "test_support.hpp"
#include "trilevel/io.hpp"

namespace fs = std::filesystem;

namespace {

/// The data beside this source file (CMake compiles it by its absolute path).
fs::path regressions_dir() { return fs::path(__FILE__).parent_path() / "data" / "fuzz_regressions"; }

/// EXPECTED: "<particles|mesh>/<file><TAB><part of the message>" per line, '#' comments.
std::map<std::string, std::string> expected_messages() {
    std::ifstream in(regressions_dir() / "EXPECTED");
    REQUIRE(in);
    std::map<std::string, std::string> out;
    for (std::string line; std::getline(in, line);) {
        if (line.empty() || line[0] == '#') continue;
        const auto tab = line.find('\t');
        REQUIRE(tab != std::string::npos);
        out[line.substr(0, tab)] = line.substr(tab + 1);
    }
    return out;
}

}  // namespace

TEST_CASE("fuzz regressions: every input that once crashed a reader is a clean one-line error", "[io][fuzz]") {
    const auto expected = expected_messages();
    std::set<std::string> on_disk;
    for (const char* kind : {"particles", "mesh"})
        if (fs::is_directory(regressions_dir() / kind))  // git keeps no empty directory
            for (const auto& e : fs::directory_iterator(regressions_dir() / kind))
                on_disk.insert(std::string(kind) + "/" + e.path().filename().string());
    std::set<std::string> listed;
    for (const auto& [name, msg] : expected) listed.insert(name);
    REQUIRE(on_disk == listed);  // no input without its expected message, no message without its input
    REQUIRE(on_disk.size() >= 5);

    for (const auto& [name, part] : expected) {
        INFO(name);
        const std::string path = (regressions_dir() / name).string();
        std::string message;
        try {
            if (name.rfind("mesh/", 0) == 0) trilevel::read_mesh(path);
            else trilevel::read_particles(path);
        } catch (const trilevel::Error& e) {
            message = e.what();
        }
        INFO(message);
        CHECK(message.rfind(path + ": ", 0) == 0);
        CHECK(message.find('\n') == std::string::npos);
        CHECK(message.find(part) != std::string::npos);
    }
}
