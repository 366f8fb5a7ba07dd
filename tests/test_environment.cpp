// The environment variables (src/environment.hpp): each one reaches its field with the documented
// parsing, unset and empty give the defaults, and every call reads them afresh.
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "environment.hpp"
#include "program_cache.hpp"

using namespace trilevel;

namespace {

/// Unsets the variables for the scope and puts back what the process had (a test run may set
/// TRILEVEL_DEVICE or the cache directory for every case).
class ClearedEnv {
public:
    explicit ClearedEnv(std::vector<std::string> names) {
        for (auto& n : names) {
            const char* v = std::getenv(n.c_str());
            saved_.push_back({n, v ? std::optional<std::string>(v) : std::nullopt});
            ::unsetenv(n.c_str());
        }
    }
    ~ClearedEnv() {
        for (const auto& [name, value] : saved_) {
            if (value) ::setenv(name.c_str(), value->c_str(), 1);
            else ::unsetenv(name.c_str());
        }
    }
    void set(const char* name, const char* value) const { ::setenv(name, value, 1); }

private:
    std::vector<std::pair<std::string, std::optional<std::string>>> saved_;
};

const std::vector<std::string> kAll = {"TRILEVEL_DEVICE",        "TRILEVEL_WORK_GROUP",   "TRILEVEL_MAX_CANDIDATES",
                                       "TRILEVEL_SERIAL_GATHER", "TRILEVEL_FINE_KEYS",    "TRILEVEL_MAX_LATTICE_STEPS",
                                       "TRILEVEL_FAULT",         "TRILEVEL_CACHE_DIR",    "XDG_CACHE_HOME",
                                       "HOME",                   "TRILEVEL_CACHE_MAX_MB", "TRILEVEL_NO_TMPFILE",
                                       "TRILEVEL_PIPELINE",      "TRILEVEL_VECTOR_WIDTH"};

void check_defaults(const EnvironmentOverrides& e) {
    CHECK(e.device.empty());
    CHECK(!e.work_group);
    CHECK(!e.max_candidates);
    CHECK(!e.serial_gather);
    CHECK(!e.vector_width);
    CHECK(!e.wide_fine_keys);
    CHECK(!e.max_lattice_steps);
    CHECK(e.fault.empty());
    CHECK(!e.cache_dir);
    CHECK(e.xdg_cache_home.empty());
    CHECK(e.home.empty());
    CHECK(!e.cache_max_bytes);
    CHECK(!e.no_tmpfile);
    CHECK(e.pipeline);
}

}  // namespace

TEST_CASE("environment: unset and empty variables give the defaults", "[environment]") {
    const ClearedEnv env(kAll);
    check_defaults(environment());
    CHECK(program_cache_dir().empty());
    for (const std::string& name : kAll)
        if (name != "TRILEVEL_CACHE_DIR") env.set(name.c_str(), "");
    check_defaults(environment());
    env.set("TRILEVEL_CACHE_DIR", "");  // the one variable where empty means something: caching off
    CHECK(environment().cache_dir == std::optional<std::string>(""));
}

TEST_CASE("environment: each variable reaches its field, parsed as documented", "[environment]") {
    const ClearedEnv env(kAll);
    env.set("TRILEVEL_DEVICE", "2x");  // kept as given: the runtime names it in its error
    env.set("TRILEVEL_WORK_GROUP", "64");
    env.set("TRILEVEL_MAX_CANDIDATES", "0");  // at least 1
    env.set("TRILEVEL_SERIAL_GATHER", "0");
    env.set("TRILEVEL_VECTOR_WIDTH", "16");
    env.set("TRILEVEL_FINE_KEYS", "64");
    env.set("TRILEVEL_MAX_LATTICE_STEPS", "80");
    env.set("TRILEVEL_FAULT", "scalar_field");
    env.set("TRILEVEL_CACHE_DIR", "/some/dir");
    env.set("TRILEVEL_CACHE_MAX_MB", "3");
    env.set("TRILEVEL_NO_TMPFILE", "1");
    env.set("TRILEVEL_PIPELINE", "0");
    EnvironmentOverrides e = environment();
    CHECK(e.device == "2x");
    CHECK(e.work_group == std::optional<std::size_t>(64));
    CHECK(e.max_candidates == std::optional<std::size_t>(1));
    CHECK(e.serial_gather == std::optional<bool>(false));
    CHECK(e.vector_width == std::optional<int>(16));
    CHECK(e.wide_fine_keys);
    CHECK(e.max_lattice_steps == std::optional<double>(80.0));
    CHECK(e.fault == "scalar_field");
    CHECK(e.cache_dir == std::optional<std::string>("/some/dir"));
    CHECK(e.cache_max_bytes == std::optional<std::uint64_t>(3ull << 20));
    CHECK(e.no_tmpfile);
    CHECK(!e.pipeline);
    CHECK(program_cache_dir() == "/some/dir");

    // Read afresh at every call: the other values of each.
    env.set("TRILEVEL_WORK_GROUP", "many");  // not a number: 0, the driver's choice
    env.set("TRILEVEL_SERIAL_GATHER", "yes");  // anything but "0" is 1
    env.set("TRILEVEL_VECTOR_WIDTH", "4");  // neither 8 nor 16: the device's default
    env.set("TRILEVEL_FINE_KEYS", "32");
    env.set("TRILEVEL_CACHE_MAX_MB", "-1");  // not a size: ignored
    env.set("TRILEVEL_NO_TMPFILE", "0");
    env.set("TRILEVEL_PIPELINE", "1");
    e = environment();
    CHECK(e.work_group == std::optional<std::size_t>(0));
    CHECK(e.serial_gather == std::optional<bool>(true));
    CHECK(!e.vector_width);
    CHECK(!e.wide_fine_keys);
    CHECK(!e.cache_max_bytes);
    CHECK(!e.no_tmpfile);
    CHECK(e.pipeline);
    CHECK(program_cache_max_bytes() == kProgramCacheMaxBytes);

    ::unsetenv("TRILEVEL_CACHE_DIR");
    env.set("HOME", "/home/someone");
    CHECK(program_cache_dir() == "/home/someone/.cache/trilevel");
    env.set("XDG_CACHE_HOME", "/xdg");
    CHECK(program_cache_dir() == "/xdg/trilevel");
}
