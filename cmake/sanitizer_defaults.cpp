// Sanitizer settings of the TRILEVEL_SANITIZE build (the object library trilevel_sanitizer_defaults),
// linked into the tests, the fuzz replay and the CLI (which the tests run), so that ctest and a hand
// run behave alike with no environment set.
// ASAN_OPTIONS / LSAN_OPTIONS / UBSAN_OPTIONS given at run time still add to or override these.

extern "C" {

// PoCL compiles the OpenCL kernels with LLVM, which keeps its allocations for the life of the
// process, and PoCL's own threads leak a little too (its kernel-cache lookup): with an empty PoCL
// kernel cache each process that builds a program "leaks" megabytes there. Only leaks allocated
// inside these two libraries are suppressed (the OpenCL ICD loader needs none): a leak of memory
// our code allocates, or any ASan/UBSan error, still fails the test. (An OpenCL object we forgot
// to release would be PoCL's allocation and go unseen; the cl:: RAII wrappers rule that out.)
const char* __lsan_default_suppressions() {
    return "leak:libLLVM\n"
           "leak:libpocl\n";
}

// No "Suppressions used" table on stderr: the CLI tests expect exactly one line there.
const char* __lsan_default_options() { return "print_suppressions=0"; }

const char* __ubsan_default_options() { return "print_stacktrace=1"; }

}  // extern "C"
