// One timed stage of a reconstruction: the pipeline reads as a list of these scopes.
//
//     {
//         StageScope stage(s, "binning", rt);   // OpenCL errors now name "binning"
//         ...                                   // the stage's work
//     }                                         // Stats::time_ms gains {"binning", ms}
//
// A stage's time runs from the scope's construction to its end (end(), else the destructor), and
// is added to Stats::time_ms under its name: appended the first time, added to the entry of that
// name when the stage runs again (band closure repeats its two stages until the band is closed),
// so the entries keep the order in which the stages first ran. A scope left by an exception
// records nothing (the reconstruction fails; no partial statistics are promised).
//
// A device stage also names itself in the runtime (OpenCLRuntime::set_stage): OpenCL errors say
// "OpenCL failure in stage <name>" and TRILEVEL_FAULT=<name> arms its fault. The name stays set
// after the scope ends, until the next stage or OpenCLRuntime::set_stage("") replaces it, so that
// host work between two stages is still named by the one before it.
#pragma once

#include <chrono>
#include <exception>

#include "opencl_runtime.hpp"
#include "trilevel/trilevel.hpp"

namespace trilevel {

class StageScope {
public:
    /// A host stage (post-processing): timed only.
    StageScope(Stats& stats, const char* name) : stats_(stats), name_(name) {}
    /// A device stage: timed, and named in `rt` for its errors and fault hook. The clock starts
    /// first: naming a stage may release pooled buffers (OpenCLRuntime::set_stage), part of its cost.
    StageScope(Stats& stats, const char* name, OpenCLRuntime& rt) : StageScope(stats, name) { rt.set_stage(name); }
    StageScope(const StageScope&) = delete;
    StageScope& operator=(const StageScope&) = delete;
    ~StageScope() {
        if (!ended_ && std::uncaught_exceptions() == unwinding_) end();
    }

    /// Records the stage's time now (once; the destructor then records nothing).
    void end() {
        if (ended_) return;
        ended_ = true;
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
        for (auto& [name, total] : stats_.time_ms)
            if (name == name_) {
                total += ms;
                return;
            }
        stats_.time_ms.emplace_back(name_, ms);
    }

private:
    Stats& stats_;
    const char* name_;
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    int unwinding_ = std::uncaught_exceptions();  ///< exceptions in flight at construction
    bool ended_ = false;
};

}  // namespace trilevel
