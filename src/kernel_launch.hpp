// One typed host function per OpenCL kernel: its name once, its arguments as C++ types in the
// order of the kernel's parameters (kernels/*.cl). A launch sets every argument and enqueues the
// kernel in one call, so no argument position or kernel name is written by hand anywhere else.
// A change to a kernel's parameter list changes its line here and no other host code compiles
// against the old one.
#pragma once

#include <cstddef>

#include "kernel_contract.hpp"
#include "opencl_runtime.hpp"

namespace trilevel::kernels {

/// Launch shape: `global` work-items in work-groups of the runtime's 1-D size (OpenCLRuntime::run).
struct Items {
    std::size_t global;
};
/// Launch shape: `groups` work-groups of `local` work-items each (OpenCLRuntime::run_groups).
struct Groups {
    std::size_t groups, local;
};

/// A __local array of `count` elements of T.
template <class T>
struct Local {
    std::size_t count;
};

/// The four __local arguments of gather_candidates (particle_binning.cl): the candidates
/// (OpenCLRuntime::max_candidates float4s), two lists of MAX_BINS bins and the count.
struct CandidateLists {
    std::size_t max_candidates;
};

namespace detail {
template <class T>
cl_uint set_arg(cl::Kernel& k, cl_uint i, const T& v) {
    k.setArg(i, v);
    return i + 1;
}
template <class T>
cl_uint set_arg(cl::Kernel& k, cl_uint i, const Local<T>& l) {
    k.setArg(i, cl::Local(l.count * sizeof(T)));
    return i + 1;
}
inline cl_uint set_arg(cl::Kernel& k, cl_uint i, const CandidateLists& c) {
    i = set_arg(k, i, Local<cl_float4>{c.max_candidates});
    i = set_arg(k, i, Local<cl_uint>{contract::kMaxBins});
    i = set_arg(k, i, Local<cl_uint>{contract::kMaxBins});
    return set_arg(k, i, Local<cl_uint>{1});
}
}  // namespace detail

/// Kernel `name` taking Args in order. Kernels of the fine-point program
/// (OpenCLRuntime::set_fine_key_bits) come from the width selected when they are launched.
template <class... Args>
class Kernel {
public:
    constexpr explicit Kernel(const char* name) : name_(name) {}
    const char* name() const { return name_; }
    void operator()(OpenCLRuntime& rt, Items shape, const Args&... args) const {
        set(rt, args...);
        rt.run(name_, shape.global);
    }
    void operator()(OpenCLRuntime& rt, Groups shape, const Args&... args) const {
        set(rt, args...);
        rt.run_groups(name_, shape.groups, shape.local);
    }

private:
    void set(OpenCLRuntime& rt, const Args&... args) const {
        cl::Kernel& k = rt.kernel(name_);
        cl_uint i = 0;
        ((i = detail::set_arg(k, i, args)), ...);
    }
    const char* name_;
};

using Buf = cl::Buffer;  // a __global pointer of any element type

// ---- particle_binning.cl (stage 1) -------------------------------------------------------------
//                                         pos  n        inv_cell keys capacity  slot_of stats
inline constexpr Kernel<Buf, cl_uint, float, Buf, cl_ulong, Buf, Buf> bin_insert{"bin_insert"};
//                                 slot_of n     count
inline constexpr Kernel<Buf, cl_uint, Buf> bin_count{"bin_count"};
//                                   slot_of n      range fill order
inline constexpr Kernel<Buf, cl_uint, Buf, Buf, Buf> bin_scatter{"bin_scatter"};
//                                         range capacity order
inline constexpr Kernel<Buf, cl_ulong, Buf> bin_sort_buckets{"bin_sort_buckets"};
//                                  order n        pos  sorted
inline constexpr Kernel<Buf, cl_uint, Buf, Buf> bin_gather{"bin_gather"};

// ---- color_field.cl (stage 2) ------------------------------------------------------------------
//   sorted occupied occupied_count per_group inv_cell bin_keys bin_capacity range R volume sheet_limit gradient flags, gather
inline constexpr Kernel<Buf, Buf, cl_uint, cl_uint, float, Buf, cl_ulong, Buf, float, float, float, Buf, Buf, CandidateLists>
    color_field{"color_field"};

// ---- surface_cells.cl (stage 3) ----------------------------------------------------------------
//   sorted flags n inv_coarse half_box cell_keys cell_capacity stats
inline constexpr Kernel<Buf, Buf, cl_uint, float, float, Buf, cl_ulong, Buf> mark_surface_cells{"mark_surface_cells"};
//   sorted flags n inv_coarse half_box cell_keys cell_capacity cell_flags interior
inline constexpr Kernel<Buf, Buf, cl_uint, float, float, Buf, cl_ulong, Buf, cl_uint> mark_cell_flags{"mark_cell_flags"};

// ---- curvature.cl (stage 4) --------------------------------------------------------------------
//   gradient_to_normal n
inline constexpr Kernel<Buf, cl_uint> particle_normals{"particle_normals"};
//   sorted flags occupied occupied_count per_group inv_cell bin_keys bin_capacity range normals R keep_kappa,
//   gather, cand_normal, inv_coarse cell_keys cell_capacity kappa_sum kappa_count kappa_max kappa
inline constexpr Kernel<Buf, Buf, Buf, cl_uint, cl_uint, float, Buf, cl_ulong, Buf, Buf, float, cl_uint, CandidateLists,
                        Local<cl_float4>, float, Buf, cl_ulong, Buf, Buf, Buf, Buf>
    particle_curvature{"particle_curvature"};
//   cells count cell_keys cell_capacity block
inline constexpr Kernel<Buf, cl_uint, Buf, cl_ulong, Buf> cell_blocks{"cell_blocks"};
//   cells count block kappa_sum kappa_count kappa_max cell_kappa
inline constexpr Kernel<Buf, cl_uint, Buf, Buf, Buf, Buf, Buf> cell_curvature{"cell_curvature"};
//   cells count block in out
inline constexpr Kernel<Buf, cl_uint, Buf, Buf, Buf> smooth_cell_curvature{"smooth_cell_curvature"};
//   cells count kappa cell_flags threshold level
inline constexpr Kernel<Buf, cl_uint, Buf, Buf, float, Buf> cell_levels{"cell_levels"};
//   cells count block cell_flags
inline constexpr Kernel<Buf, cl_uint, Buf, Buf> cell_thin_bodies{"cell_thin_bodies"};

// ---- hash_table.cl -----------------------------------------------------------------------------
//   old_keys old_values old_capacity keys values capacity shift stats
inline constexpr Kernel<Buf, Buf, cl_ulong, Buf, Buf, cl_ulong, cl_uint2, Buf> fine_rehash{"fine_rehash"};

// ---- refine_points.cl (stage 5) ----------------------------------------------------------------
//   cells cell_count coarse_steps keys capacity stats shift
inline constexpr Kernel<Buf, cl_uint, cl_int, Buf, cl_ulong, Buf, cl_uint2> refine_points{"refine_points"};

// ---- scalar_field.cl (stage 6) -----------------------------------------------------------------
//   keys values capacity count pending
inline constexpr Kernel<Buf, Buf, cl_ulong, Buf, Buf> collect_pending{"collect_pending"};
//   pending count keys values step sorted inv_cell bin_keys bin_capacity range r R shift
inline constexpr Kernel<Buf, cl_uint, Buf, Buf, float, Buf, float, Buf, cl_ulong, Buf, float, float, cl_uint2>
    scalar_field{"scalar_field"};
//   cells coarse_steps claim keys capacity value_bits step sorted inv_cell bin_keys bin_capacity range r R
//   overflow, bin_start, bin_count, claimed, claimed_count, cells_are_bins table_stats shift, columns
inline constexpr Kernel<Buf, cl_int, cl_int, Buf, cl_ulong, Buf, float, Buf, float, Buf, cl_ulong, Buf, float, float, Buf,
                        Local<cl_uint>, Local<cl_uint>, Local<cl_uint>, Local<cl_uint>, cl_int, Buf, cl_uint2,
                        Local<cl_float>>
    scalar_field_cells{"scalar_field_cells"};

}  // namespace trilevel::kernels
