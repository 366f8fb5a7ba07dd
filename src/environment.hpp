// The environment variables trilevel reads, in one place. Nothing else in the library or the CLI
// calls getenv: each user calls environment() where it needs a value and takes its field.
//
// environment() reads the variables afresh at every call (a dozen getenv, no cache), so a change
// between two calls is seen by the second: the tests set and unset them with setenv between cases.
// "Read" below says when each user calls it. Unset and empty mean the same (the default), except
// for TRILEVEL_CACHE_DIR, where empty turns the cache off.
// docs/operations.md#environment-variables lists them for users.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace trilevel {

struct EnvironmentOverrides {
    // --- device and kernels (users and tests) ---

    /// TRILEVEL_DEVICE: the OpenCL device index (`trilevel devices`) when the caller names none
    /// (Reconstructor(-1), the CLI without --device, Python's device=-1). The text as given:
    /// OpenCLRuntime rejects anything but a whole number >= 0 with an error naming it.
    /// Read when a Reconstructor opens its device. Default: the first GPU, else the first CPU device.
    std::string device;

    /// TRILEVEL_WORK_GROUP=N: the work-group size of the 1-D kernel launches (0: the driver
    /// chooses; not a number reads as 0). Tests: every size gives the same mesh. Read when a
    /// Reconstructor opens its device. Default: OpenCLRuntime::kDefaultWorkGroup within the device's limit.
    std::optional<std::size_t> work_group;

    /// TRILEVEL_MAX_CANDIDATES=N (at least 1): lowers the candidate particles a work-group gathers
    /// into local memory, so that the overflow fallbacks run (tests). Read when a Reconstructor
    /// opens its device. Default: what the device's local memory holds, at most 2048.
    std::optional<std::size_t> max_candidates;

    /// TRILEVEL_SERIAL_GATHER=0|1 (anything but "0" is 1): one work-item copies a gather's
    /// candidates (1) or all of them do (0). Tests: both give the same bits. Read when a program
    /// is built. Default: 1 on CPU devices, 0 on others.
    std::optional<bool> serial_gather;

    /// TRILEVEL_VECTOR_WIDTH=8|16 (anything else: unset): the lanes of the field kernel's and the
    /// colour field's vectors (points or particles a work-item takes at once). Tests: both give the
    /// same bits. Read when a program is built. Default: 16 on CPU devices that prefer 16-wide
    /// float vectors, else 8.
    std::optional<int> vector_width;

    /// TRILEVEL_FINE_KEYS=64: 64-bit fine-point keys even where the lattice fits 32-bit ones
    /// (tests: both give the same mesh; bench). Read at each reconstruction. Default: 32-bit keys
    /// when the lattice fits them.
    bool wide_fine_keys = false;

    /// TRILEVEL_MAX_LATTICE_STEPS=N: lowers the lattice extent one lattice takes (clamped to
    /// [64, lattice::kMaxCoord]), so that small scenes take the split path of domain_split.hpp
    /// (tests). Read at each reconstruction. Default: lattice::kMaxCoord.
    std::optional<double> max_lattice_steps;

    /// TRILEVEL_FAULT=stage: the first launch, wait or allocation in that pipeline stage
    /// ("binning", "scalar_field", ...) fails as if the device had returned CL_OUT_OF_RESOURCES
    /// (tests: OpenCLRuntime::inject_fault). Read at each reconstruction. Default: no fault.
    std::string fault;

    // --- program cache (users) ---

    /// TRILEVEL_CACHE_DIR: where compiled programs are kept; set but empty turns the cache off
    /// (program_cache.hpp, program_cache_dir). Read when a program is built. Default (unset):
    /// $XDG_CACHE_HOME/trilevel, else $HOME/.cache/trilevel.
    std::optional<std::string> cache_dir;
    /// XDG_CACHE_HOME and HOME, the standard variables behind the default cache directory.
    std::string xdg_cache_home, home;

    /// TRILEVEL_CACHE_MAX_MB=N: the cache's size limit, whole MiB (0: only the entry in use), as
    /// bytes; a value that is not such a number (a sign, other characters, over 2^40) is ignored.
    /// Read when a program is stored. Default: kProgramCacheMaxBytes (64 MiB).
    std::optional<std::uint64_t> cache_max_bytes;

    // --- output files and the CLI ---

    /// TRILEVEL_NO_TMPFILE=1 (a value starting with 1): output files are written through a named
    /// temporary beside the target, the path of file systems without O_TMPFILE (tests). Read at
    /// each output file. Default: an unnamed O_TMPFILE where the system has it.
    bool no_tmpfile = false;

    /// TRILEVEL_PIPELINE=0: the CLI meshes a sequence one frame at a time (read, mesh, write),
    /// without a FramePipeline: the lowest memory (tests compare the two). Read at each CLI
    /// sequence. Default: pipelined.
    bool pipeline = true;

    /// TRILEVEL_PIPELINE_FINISHER=0 or 1: a FramePipeline triangulates and post-processes frame k
    /// on a thread of its own while frame k+1's device stages run (pipeline.hpp), off or on. Read
    /// when a FramePipeline is made. Default (unset): on where the device is not a CPU, whose
    /// stages already keep the host's cores busy (on 2 cores it gained nothing measurable and held
    /// one more frame: bench/RESULTS-sequences.md).
    std::optional<bool> pipeline_finisher;
};

/// The variables as they are now.
EnvironmentOverrides environment();

}  // namespace trilevel
