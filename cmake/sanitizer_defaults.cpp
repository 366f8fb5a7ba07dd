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

// The leak check at exit walks each thread's dynamic TLS blocks, which the sanitizer records by
// intercepting __tls_get_addr. On Debian 12 (GCC 12's runtime, glibc 2.36) that record can hold a
// bogus block after PoCL has dlopen'ed its kernel libraries, and the check then dies with "Tracer
// caught signal 11" and fails the process although nothing leaked. Seen at stop 31 in the test that
// builds the kernels from source ("a runtime loads its program from the disk cache ..."), every run
// on one machine, never with POCL_CACHE_DIR set: it depends on the process's memory layout. Without
// the interception the check still scans stacks, registers, static TLS and globals.
const char* __asan_default_options() { return "intercept_tls_get_addr=0"; }

const char* __ubsan_default_options() { return "print_stacktrace=1"; }

}  // extern "C"
