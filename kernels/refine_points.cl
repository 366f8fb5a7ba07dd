// Stage 5 (paper §3.2, eq. 4-6 made sparse; docs/design.md §5): every coarse surface cell inserts its fine
// lattice points into the lock-free hash: (n/2+1)^3 for level 2 (27 when n = 4), (n+1)^3 for
// level 3 (125). A point shared by several cells is stored once; its value slot starts as NaN,
// which marks it as not yet evaluated.
// Uses: contract.h (CELL_*), hash_table.cl (fine_insert).

// A cell's w: its level, plus CELL_CUBE_CENTRES where the level-2 check (host/level2_check.hpp)
// needs the centres of its level-2 cubes, which the same passes then insert and evaluate.
// (CELL_CUBE_CENTRES and CELL_LEVEL_MASK: contract.h.)
inline int cell_level(int w) { return w & CELL_LEVEL_MASK; }

// Whether the cell whose int4 has this w holds the lattice point with `odd` odd coordinates (of
// its local offset): level 3 every point, level 2 the even ones and, when asked, the cube centres.
inline bool cell_has_point(int w, int odd) {
    return cell_level(w) != 2 || odd == 0 || ((w & CELL_CUBE_CENTRES) && odd == 3);
}

// Local offset (x, y, z) of the l-th point of a cube `side` points wide, x fastest, without an
// integer division (the lattice loops take three per point, which cost as much as the rest of the
// loop on CPUs): l / side as (l * recip) >> 32, recip = lattice_reciprocal(side), which is exact for
// l < 2^32 / side, so for every point of a cube up to 255 points wide.
inline ulong lattice_reciprocal(int side) { return (0x100000000UL + (ulong)side - 1) / (ulong)side; }
inline int3 lattice_offset(int l, int side, ulong recip) {
    const int q = (int)(((ulong)l * recip) >> 32), z = (int)(((ulong)q * recip) >> 32);
    return (int3)(l - q * side, q - z * side, z);
}

// cells: x, y, z = coarse coordinates, w = level (| CELL_CUBE_CENTRES). One work-item per (cell, local point).
__kernel void refine_points(__global const int4* cells, uint cell_count, int coarse_steps,
                            volatile __global fine_key_t* keys, ulong capacity, volatile __global int* stats,
                            uint2 shift) {
    uint gid = get_global_id(0);
    int side = coarse_steps + 1;
    uint per_cell = (uint)(side * side * side);
    if (gid >= cell_count * per_cell) return;
    int4 c = cells[gid / per_cell];
    int l = (int)(gid % per_cell);
    int3 o = lattice_offset(l, side, lattice_reciprocal(side));
    if (!cell_has_point(c.w, (o.x & 1) + (o.y & 1) + (o.z & 1))) return;
    int3 p = c.xyz * coarse_steps + o;
    fine_insert_counted(keys, capacity, p, shift, stats);
}

// Lists the slots whose value is still NaN (inserted, not evaluated).
__kernel void collect_pending(__global const fine_key_t* keys, __global const float* values, ulong capacity,
                              volatile __global uint* count, __global uint* pending) {
    ulong s = get_global_id(0);
    if (s >= capacity) return;
    if (keys[s] != FINE_EMPTY && isnan(values[s])) pending[atomic_inc(count)] = (uint)s;
}
