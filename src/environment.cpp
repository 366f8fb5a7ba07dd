#include "environment.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>

namespace trilevel {

namespace {

/// The variable's value when it is set and not empty.
const char* value_of(const char* name) {
    const char* v = std::getenv(name);
    return v && *v ? v : nullptr;
}

}  // namespace

EnvironmentOverrides environment() {
    EnvironmentOverrides e;
    if (const char* v = value_of("TRILEVEL_DEVICE")) e.device = v;
    if (const char* v = value_of("TRILEVEL_WORK_GROUP")) e.work_group = std::strtoul(v, nullptr, 10);
    if (const char* v = value_of("TRILEVEL_MAX_CANDIDATES"))
        e.max_candidates = std::max(1ul, std::strtoul(v, nullptr, 10));
    if (const char* v = value_of("TRILEVEL_SERIAL_GATHER")) e.serial_gather = std::strcmp(v, "0") != 0;
    if (const char* v = value_of("TRILEVEL_VECTOR_WIDTH"); v && (std::strcmp(v, "8") == 0 || std::strcmp(v, "16") == 0))
        e.vector_width = std::atoi(v);
    if (const char* v = value_of("TRILEVEL_FINE_KEYS")) e.wide_fine_keys = std::strcmp(v, "64") == 0;
    if (const char* v = value_of("TRILEVEL_MAX_LATTICE_STEPS")) e.max_lattice_steps = std::strtod(v, nullptr);
    if (const char* v = value_of("TRILEVEL_FAULT")) e.fault = v;

    if (const char* v = std::getenv("TRILEVEL_CACHE_DIR")) e.cache_dir = v;  // "" turns the cache off
    if (const char* v = value_of("XDG_CACHE_HOME")) e.xdg_cache_home = v;
    if (const char* v = value_of("HOME")) e.home = v;
    if (const char* v = value_of("TRILEVEL_CACHE_MAX_MB")) {
        char* end = nullptr;
        const unsigned long long mb = std::strtoull(v, &end, 10);
        if (*end == '\0' && *v != '-' && mb <= (1ull << 40)) e.cache_max_bytes = std::uint64_t(mb) << 20;
    }

    if (const char* v = value_of("TRILEVEL_NO_TMPFILE")) e.no_tmpfile = *v == '1';
    if (const char* v = value_of("TRILEVEL_PIPELINE")) e.pipeline = std::strcmp(v, "0") != 0;
    if (const char* v = value_of("TRILEVEL_PIPELINE_FINISHER")) e.pipeline_finisher = std::strcmp(v, "0") != 0;
    return e;
}

}  // namespace trilevel
