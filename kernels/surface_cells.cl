// Stage 3 (paper §3, docs/design.md §2): the sparse set of coarse surface cells. Every surface or splash
// particle marks the coarse cells overlapping the box x ± half (the paper's AABB of 4r around a
// surface particle); cells within R of a splash particle become splash cells (forced level 3).
// Coarse cells are keys in a hash, never a dense box (docs/design.md §4).

// Uses: contract.h (CELL_SPLASH, CELL_INTERIOR, FLAG_*), hash_table.cl.

inline int3 coarse_of(float3 p, float inv_coarse) {
    return convert_int3_rtn(p * inv_coarse);
}

__kernel void mark_surface_cells(__global const float* sorted, __global const uchar* flags, uint n,
                                 float inv_coarse, float half_box,
                                 volatile __global ulong* cell_keys, ulong cell_capacity,
                                 volatile __global int* stats) {
    uint i = get_global_id(0);
    if (i >= n || flags[i] == 0) return;
    int3 lo = coarse_of(vload3(i, sorted) - half_box, inv_coarse);
    int3 hi = coarse_of(vload3(i, sorted) + half_box, inv_coarse);
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x)
                hash_insert_counted(cell_keys, cell_capacity, pack_key((int3)(x, y, z)), stats);
}

// The surface cells' flags from the particles, in one pass: CELL_SPLASH on the cells overlapping
// x +- half_box of a splash or thin particle (forced level 3), and with `interior` (adaptive mode)
// CELL_INTERIOR on the cell that holds a particle inside the fluid (no flag; curvature.cl,
// cell_thin_bodies). Particles come in bin order, so only the first of a run of those in one cell
// looks the cell up.
__kernel void mark_cell_flags(__global const float* sorted, __global const uchar* flags, uint n, float inv_coarse,
                              float half_box, __global const ulong* cell_keys, ulong cell_capacity,
                              volatile __global uint* cell_flags, uint interior) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    const uchar f = flags[i];
    const float3 x = vload3(i, sorted);
    if (f == 0) {
        if (!interior) return;
        const int3 c = coarse_of(x, inv_coarse);
        if (i > 0 && flags[i - 1] == 0 && all(coarse_of(vload3(i - 1, sorted), inv_coarse) == c)) return;
        const long s = hash_find(cell_keys, cell_capacity, pack_key(c));
        if (s >= 0) atomic_or(&cell_flags[s], CELL_INTERIOR);
        return;
    }
    if ((f & (FLAG_SPLASH | FLAG_THIN)) == 0) return;
    const int3 lo = coarse_of(x - half_box, inv_coarse), hi = coarse_of(x + half_box, inv_coarse);
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x) {
                long s = hash_find(cell_keys, cell_capacity, pack_key((int3)(x, y, z)));
                if (s >= 0) atomic_or(&cell_flags[s], CELL_SPLASH);
            }
}
