// Stage 4 (paper eq. 1-3, docs/design.md §3.2): curvature per surface particle, its mean per coarse cell
// and the level of each cell. Cell sums use 64-bit fixed-point atomics so the mean does not depend
// on the order in which work-items add (docs/design.md §6).

// Uses: contract.h (KAPPA_FIXED, FLAG_SURFACE, CELL_SPLASH, CELL_INTERIOR, CELL_THIN_BODY), hash_table.cl,
// particle_binning.cl, surface_cells.cl (coarse_of).

inline float3 outward_normal(float3 gradient) {
    return length(gradient) > 0.0f ? -normalize(gradient) : (float3)(0.0f);
}

// Outward unit normal per sorted particle (packed xyz), written over its colour-field gradient (not
// needed after this), so the curvature loop reads a normal instead of normalising a gradient, and no
// second array of n normals is allocated.
__kernel void particle_normals(__global float* gradient_to_normal, uint n) {
    uint i = get_global_id(0);
    if (i < n) vstore3(outward_normal(vload3(i, gradient_to_normal)), i, gradient_to_normal);
}

// After gather_candidates (devices other than CPUs; those use gather_surface_candidates): the
// candidates' normals, in the same order, with w = 1 for surface particles and 0 for the others.
inline void gather_normals(int3 blo, int3 bhi, __global const float* normals, __global const uchar* flags,
                           __global const uint2* range, __local float4* dst, __local const uint* bin_first,
                           __local const uint* bin_slot) {
    const uint lid = get_local_id(0), lsize = get_local_size(0);
    const int3 bn = bhi - blo + 1;
    const int nbins = bn.x * bn.y * bn.z;
    const uint first = SERIAL_GATHER ? (lid == 0 ? 0 : UINT_MAX) : lid, stride = SERIAL_GATHER ? 1 : lsize;
    for (int b = 0; b < nbins && first != UINT_MAX; ++b) {
        if ((int)bin_slot[b] < 0) continue;
        uint2 rg = range[bin_slot[b]];
        for (uint k = first; k < rg.y; k += stride) {
            const uint j = rg.x + k;
            dst[bin_first[b] + k] = (float4)(vload3(j, normals), (flags[j] & FLAG_SURFACE) ? 1.0f : 0.0f);
        }
    }
    barrier(CLK_LOCAL_MEM_FENCE);
}

// CPU devices (SERIAL_GATHER): the surface candidates of bins blo..bhi only, positions to `cand`
// and normals (w = 1) to `dst`, in the order gather_candidates lists them, by work-item 0. Only
// surface neighbours add to eq. 1, so the sums are those of the full list, bit for bit, over fewer
// candidates (about a third of them on the dam-break frames). Returns their number, or
// MAX_CANDIDATES + 1 when they do not fit (global-memory fallback).
inline uint gather_surface_candidates(int3 blo, int3 bhi, __global const float* sorted, __global const float* normals,
                                      __global const uchar* flags, __global const ulong* bin_keys, ulong bin_capacity,
                                      __global const uint2* range, __local float4* cand, __local float4* dst,
                                      __local uint* count) {
    if (get_local_id(0) == 0) {
        uint total = 0;
        for (int z = blo.z; z <= bhi.z; ++z)
            for (int y = blo.y; y <= bhi.y; ++y)
                for (int x = blo.x; x <= bhi.x; ++x) {
                    const int3 q = (int3)(x, y, z);
                    const long s = key_in_range(q) ? hash_find(bin_keys, bin_capacity, pack_key(q)) : -1;
                    if (s < 0) continue;
                    const uint2 rg = range[s];
                    for (uint j = rg.x; j < rg.x + rg.y; ++j) {
                        if (!(flags[j] & FLAG_SURFACE)) continue;
                        if (total < MAX_CANDIDATES) {
                            cand[total] = candidate(sorted, j);
                            dst[total] = (float4)(vload3(j, normals), 1.0f);
                        }
                        ++total;
                    }
                }
        *count = total <= MAX_CANDIDATES ? total : MAX_CANDIDATES + 1;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    return *count;
}

// Paper eq. 1-2 for surface particle i over the 27 bins around it in global memory (bins whose
// candidates do not fit in local memory).
inline float curvature_global(uint i, __global const float* sorted, __global const uchar* flags, float inv_cell,
                              __global const ulong* bin_keys, ulong bin_capacity, __global const uint2* range,
                              __global const float* normals, float R) {
    const float4 xi = candidate(sorted, i);
    const float3 ni = vload3(i, normals);
    float kap = 0.0f;
    FOR_EACH_NEIGHBOUR_BIN(xi, inv_cell, bin_keys, bin_capacity, range, sorted, {
        if (j != i && (flags[j] & FLAG_SURFACE)) {
            float d = length(xi.xyz - pj.xyz);
            if (d < R) kap += (1.0f - dot(ni, vload3(j, normals))) * (1.0f - d / R);
        }
    })
    return kap;
}

// Paper eq. 3: adds surface particle i's kappa to the sum and count of the coarse cell it lies in,
// and to the cell's largest kappa (as float bits: non-negative floats order like their bits).
// Fixed-point sums do not depend on the order of the adds (docs/design.md §6).
inline void add_to_cell(float3 x, float kap, float inv_coarse, __global const ulong* cell_keys, ulong cell_capacity,
                        volatile __global ulong* kappa_sum, volatile __global uint* kappa_count,
                        volatile __global uint* kappa_max) {
    long s = hash_find(cell_keys, cell_capacity, pack_key(coarse_of(x, inv_coarse)));
    if (s < 0) return;
    atom_add(&kappa_sum[s], (ulong)(kap * KAPPA_FIXED + 0.5f));
    atomic_inc(&kappa_count[s]);
    atomic_max(&kappa_max[s], as_uint(kap));
}

// Particles of a bin whose surface ones particle_curvature lists at a time (8 lanes for each
// of the kBinGroup work-items of src/device_stages.cpp).
#define SURFACE_CHUNK 64

// What particle_curvature does with particle i's kappa: into its cell's sums, so that no array of n
// floats is needed, and into kappa[i] only when the caller asked for them (tests, diagnostics).
// Clamped at 0: 1 - n_i . n_j rounds below zero for parallel normals, and a negative kappa would
// wrap the unsigned fixed-point sum and, as bits, rank above every positive kappa in the maximum.
#define CURVATURE_RESULT(i, kap)                                                                          \
    {                                                                                                     \
        const float kap_ = fmax((kap), 0.0f);                                                             \
        if (flags[i] & FLAG_SURFACE)                                                                      \
            add_to_cell(vload3(i, sorted), kap_, inv_coarse, cell_keys, cell_capacity, kappa_sum, kappa_count, \
                        kappa_max);                                                                       \
        if (keep_kappa) kappa[i] = kap_;                                                                  \
    }

// Paper eq. 1-2: kappa_i = sum_j (1 - n_i . n_j) W(x_ij, h), W = max(0, 1 - |x_ij|/h), h = R, over
// the surface neighbours j. Work-groups take bins in turn with candidates (positions and
// normals) in local memory; a work-item takes 8 particles at once, one per vector lane, each
// adding its neighbours in candidate order (as in color_field).
__kernel void particle_curvature(__global const float* sorted, __global const uchar* flags,
                                 __global const uint* occupied, uint occupied_count, uint per_group, float inv_cell,
                                 __global const ulong* bin_keys, ulong bin_capacity, __global const uint2* range,
                                 __global const float* normals, float R, uint keep_kappa,
                                 __local float4* cand, __local uint* bin_first, __local uint* bin_slot,
                                 __local uint* count, __local float4* cand_normal, float inv_coarse,
                                 __global const ulong* cell_keys, ulong cell_capacity, volatile __global ulong* kappa_sum,
                                 volatile __global uint* kappa_count, volatile __global uint* kappa_max,
                                 __global float* kappa) {
    __local uint surface_list[SURFACE_CHUNK];
    __local uint surface_count[1];
    const uint lid = get_local_id(0), lsize = get_local_size(0);
    const uint first_bin = get_group_id(0) * per_group;
    for (uint ob = first_bin; ob < min(first_bin + per_group, occupied_count); ++ob) {
        barrier(CLK_LOCAL_MEM_FENCE);  // the previous bin is done with the candidates
        const uint2 own = range[occupied[ob]];
        uint surface = 0;  // most bins lie inside the fluid: nothing to do there
        for (uint k = 0; k < own.y; ++k) surface |= flags[own.x + k] & FLAG_SURFACE;
        if (!surface) {
            for (uint k = lid; keep_kappa && k < own.y; k += lsize) kappa[own.x + k] = 0.0f;
            continue;
        }
        const int3 bin = cell_of(vload3(own.x, sorted), inv_cell);
        const uint n_cand = SERIAL_GATHER ? gather_surface_candidates(bin - 1, bin + 1, sorted, normals, flags, bin_keys,
                                                                      bin_capacity, range, cand, cand_normal, count)
                                          : gather_candidates(bin - 1, bin + 1, sorted, bin_keys, bin_capacity, range,
                                                              cand, bin_first, bin_slot, count);
        if (n_cand > MAX_CANDIDATES) {
            for (uint k = lid; k < own.y; k += lsize) {
                const uint i = own.x + k;
                const float kap =
                    (flags[i] & FLAG_SURFACE)
                        ? curvature_global(i, sorted, flags, inv_cell, bin_keys, bin_capacity, range, normals, R)
                        : 0.0f;
                CURVATURE_RESULT(i, kap);
            }
            continue;
        }
        if (!SERIAL_GATHER) gather_normals(bin - 1, bin + 1, normals, flags, range, cand_normal, bin_first, bin_slot);
        // The lanes take the bin's surface particles only, SURFACE_CHUNK particles of the bin at a
        // time: the others' kappa is 0 and adds to no cell, and a lane's sum does not depend on its
        // partners, so the results keep their bits with about half the vector iterations (a bin
        // holds some 14 particles at x64, a third of them on the surface).
        const float inv_R = 1.0f / R;
        for (uint chunk = 0; chunk < own.y; chunk += SURFACE_CHUNK) {
            barrier(CLK_LOCAL_MEM_FENCE);  // the previous chunk's lanes are loaded
            if (lid == 0) {
                uint m = 0;
                for (uint k = chunk; k < min(chunk + SURFACE_CHUNK, own.y); ++k) {
                    const uint i = own.x + k;
                    if (flags[i] & FLAG_SURFACE) surface_list[m++] = i;
                    else if (keep_kappa) kappa[i] = 0.0f;
                }
                *surface_count = m;
            }
            barrier(CLK_LOCAL_MEM_FENCE);
            const uint m = *surface_count;
            for (uint first = lid * 8; first < m; first += lsize * 8) {
                float px[8], py[8], pz[8], nx[8], ny[8], nz[8];
                uint ids[8];
                for (int l = 0; l < 8; ++l) {  // spare lanes repeat the last particle
                    const uint i = surface_list[min(first + l, m - 1)];
                    const float3 x = vload3(i, sorted);
                    const float3 n = vload3(i, normals);
                    px[l] = x.x; py[l] = x.y; pz[l] = x.z; nx[l] = n.x; ny[l] = n.y; nz[l] = n.z; ids[l] = i;
                }
                const float8 X = vload8(0, px), Y = vload8(0, py), Z = vload8(0, pz);
                const float8 NX = vload8(0, nx), NY = vload8(0, ny), NZ = vload8(0, nz);
                const uint8 I = vload8(0, ids);
                float8 kap = 0.0f;
                for (uint j = 0; j < n_cand; ++j) {
                    const float4 nj = cand_normal[j];
                    if (nj.w == 0.0f) continue;  // not a surface particle: the same for every lane
                    const float4 pj = cand[j];
                    const float8 dx = X - pj.x, dy = Y - pj.y, dz = Z - pj.z;
                    const float8 d = sqrt(dx * dx + dy * dy + dz * dz);
                    const int8 in = (d < R) & (I != (uint8)as_uint(pj.w));
                    const float8 term = (1.0f - (NX * nj.x + NY * nj.y + NZ * nj.z)) * (1.0f - d * inv_R);
                    kap += select((float8)(0.0f), term, in);
                }
                float out[8];
                vstore8(kap, 0, out);
                for (uint l = 0; l < 8 && first + l < m; ++l) CURVATURE_RESULT(surface_list[first + l], out[l]);
            }
        }
    }
}

#define NO_CELL 0xFFFFFFFFu

// The table slot of each coarse cell of the 3x3x3 block around every listed cell, in z, y, x order
// (NO_CELL where there is none): block[k * count + i] for block cell k of list entry i. Looked up
// once for the passes below, which then read slots instead of probing the hash 27 times each.
__kernel void cell_blocks(__global const uint* cells, uint count, __global const ulong* cell_keys, ulong cell_capacity,
                          __global uint* block) {
    const uint i = get_global_id(0);
    if (i >= count) return;
    const int3 c = unpack_key(cell_keys[cells[i]]);
    uint k = 0;
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx, ++k) {
                const int3 q = c + (int3)(dx, dy, dz);
                const long t = key_in_range(q) ? hash_find(cell_keys, cell_capacity, pack_key(q)) : -1;
                block[k * count + i] = t < 0 ? NO_CELL : (uint)t;
            }
}

// Paper eq. 3 per coarse cell. A cell without surface particles takes the largest curvature found
// in its 26 neighbours (docs/design.md §3.2).
__kernel void cell_curvature(__global const uint* cells, uint count, __global const uint* block,
                             __global const ulong* kappa_sum, __global const uint* kappa_count,
                             __global const uint* kappa_max, __global float* cell_kappa) {
    const uint i = get_global_id(0);
    if (i >= count) return;
    const uint s = cells[i];
    if (kappa_count[s] > 0) {
        cell_kappa[s] = ((float)kappa_sum[s] / KAPPA_FIXED) / (float)kappa_count[s];
        return;
    }
    uint m = 0;
    for (uint k = 0; k < 27; ++k) {
        const uint t = block[k * count + i];
        if (t != NO_CELL) m = max(m, kappa_max[t]);
    }
    cell_kappa[s] = as_float(m);
}

// One smoothing pass (beyond the paper): the mean of `in` over the surface cells of the 3x3x3 block
// around each cell, summed in z, y, x order (docs/design.md §6). constants::kCurvatureSmoothingPasses passes
// keep level regions compact on noisy curvature: fewer transition faces, fewer crack patches.
__kernel void smooth_cell_curvature(__global const uint* cells, uint count, __global const uint* block,
                                    __global const float* in, __global float* out) {
    const uint i = get_global_id(0);
    if (i >= count) return;
    const uint s = cells[i];
    float sum = 0.0f, n = 0.0f;
    for (uint k = 0; k < 27; ++k) {
        const uint t = block[k * count + i];
        const float v = in[t == NO_CELL ? s : t];  // branch-free: a missing cell adds +0
        sum += t == NO_CELL ? 0.0f : v;
        n += t == NO_CELL ? 0.0f : 1.0f;
    }
    out[s] = sum / n;
}

// CELL_THIN_BODY on each listed cell whose 3x3x3 block (cell_blocks) has no CELL_INTERIOR cell: a
// rod, torus or sheet a few particles thick, a droplet (the level-2 check takes it whatever its
// curvature, constants::kThinBodyTolerance).
__kernel void cell_thin_bodies(__global const uint* cells, uint count, __global const uint* block,
                               volatile __global uint* cell_flags) {
    const uint i = get_global_id(0);
    if (i >= count) return;
    uint interior = 0;
    for (uint k = 0; k < 27; ++k) {
        const uint t = block[k * count + i];
        if (t != NO_CELL) interior |= cell_flags[t] & CELL_INTERIOR;
    }
    if (!interior) atomic_or(&cell_flags[cells[i]], CELL_THIN_BODY);
}

// Level per coarse cell: 3 if a splash or thin particle is near or if its smoothed curvature reaches
// the threshold; else 2.
__kernel void cell_levels(__global const uint* cells, uint count, __global const float* kappa,
                          __global const uint* cell_flags, float threshold, __global uchar* level) {
    if (get_global_id(0) >= count) return;
    const uint s = cells[get_global_id(0)];
    level[s] = ((cell_flags[s] & CELL_SPLASH) || kappa[s] >= threshold) ? 3 : 2;
}
