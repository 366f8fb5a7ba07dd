// Helpers for the tests that run the CLI binary (TRILEVEL_CLI) as a user would.
#pragma once

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

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
inline CliResult run_cli_raw(const TempDir& tmp, const std::string& args) {
    const std::string out = tmp.file("stdout.txt"), err = tmp.file("stderr.txt");
    const std::string cmd = std::string("'") + TRILEVEL_CLI + "' " + args + " >'" + out + "' 2>'" + err + "'";
    const int rc = std::system(cmd.c_str());
    return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, slurp(out), slurp(err)};
}

/// The first line a cold start prints on stderr (the kernels are compiled: test_first_run.cpp).
inline constexpr const char* kCompileNotice = "trilevel: compiling OpenCL kernels for ";

/// `err` without that notice: whether a run found the program cache cold depends on the tests that
/// ran before it, not on what the other CLI tests check.
inline std::string without_compile_notice(std::string err) {
    for (auto at = err.find(kCompileNotice); at != std::string::npos; at = err.find(kCompileNotice, at))
        if (at == 0 || err[at - 1] == '\n') err.erase(at, err.find('\n', at) - at + 1);
        else ++at;
    return err;
}

/// run_cli_raw without the compile notice in stderr.
inline CliResult run_cli(const TempDir& tmp, const std::string& args) {
    CliResult r = run_cli_raw(tmp, args);
    r.err = without_compile_notice(std::move(r.err));
    return r;
}

}  // namespace trilevel::test
