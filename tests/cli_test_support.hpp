// Helpers for the tests that run the CLI binary (TRILEVEL_CLI) as a user would.
#pragma once

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h>

#include "test_support.hpp"

namespace trilevel::test {

/// The whole content of a file ("" when it cannot be read).
inline std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

struct CliResult {
    int code = -1;
    std::string out, err;
};

/// Runs the CLI with `args` (already shell-quoted where needed), stdout and stderr to files (not a
/// terminal: plain progress lines, no bar), and returns the exit code and both streams.
inline CliResult run_cli(const TempDir& tmp, const std::string& args) {
    const std::string out = tmp.file("stdout.txt"), err = tmp.file("stderr.txt");
    const std::string cmd = std::string("'") + TRILEVEL_CLI + "' " + args + " >'" + out + "' 2>'" + err + "'";
    const int rc = std::system(cmd.c_str());
    return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(out), slurp(err)};
}

}  // namespace trilevel::test
