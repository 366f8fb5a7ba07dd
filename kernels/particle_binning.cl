// Stage 1 (DESIGN §2): bin particles into a sparse grid of cell R by a stable counting sort.
// Positions are relative to the lattice origin (the host subtracts it in double precision), so
// cells are floor(p / cell) and far-from-origin scenes keep float precision.
// Occupied cells are keys in the lock-free hash; their slots serve as counting-sort buckets:
// count -> (host) exclusive scan -> scatter -> sort each bucket by particle index, so every
// neighbour sum later runs in the same order whatever the thread count (DESIGN §6).

inline int3 cell_of(float4 p, float inv_cell) {
    return convert_int3_rtn(p.xyz * inv_cell);
}

__kernel void bin_insert(__global const float4* pos, uint n, float inv_cell,
                         volatile __global ulong* keys, ulong mask, __global int* slot_of,
                         volatile __global int* stats) {
    uint i = get_global_id(0);
    if (i >= n) return;
    slot_of[i] = (int)hash_insert_counted(keys, mask, pack_key(cell_of(pos[i], inv_cell)), stats);
}

__kernel void bin_count(__global const int* slot_of, uint n, volatile __global uint* count) {
    uint i = get_global_id(0);
    if (i >= n) return;
    atomic_inc(&count[slot_of[i]]);
}

__kernel void bin_scatter(__global const int* slot_of, uint n, __global const uint2* range,
                          volatile __global uint* fill, __global uint* order) {
    uint i = get_global_id(0);
    if (i >= n) return;
    int s = slot_of[i];
    order[range[s].x + atomic_inc(&fill[s])] = i;
}

// Restores index order inside each bucket (buckets hold about (R / 2r)^3 = 8 particles).
__kernel void bin_sort_buckets(__global const uint2* range, ulong capacity, __global uint* order) {
    ulong s = get_global_id(0);
    if (s >= capacity) return;
    uint b = range[s].x, n = range[s].y;
    for (uint a = b + 1; a < b + n; ++a) {
        uint v = order[a];
        uint c = a;
        while (c > b && order[c - 1] > v) { order[c] = order[c - 1]; --c; }
        order[c] = v;
    }
}

__kernel void bin_gather(__global const uint* order, uint n, __global const float4* pos, __global float4* sorted) {
    uint i = get_global_id(0);
    if (i >= n) return;
    sorted[i] = pos[order[i]];
}

// Neighbour loop over the 27 bins around `x`; used by every particle and grid-point stage.
// BODY sees `float4 pj` and `uint j` (index into sorted arrays).
#define FOR_EACH_NEIGHBOUR_BIN(X_, INV_CELL_, KEYS_, MASK_, RANGE_, SORTED_, BODY)              \
    {                                                                                                  \
        int3 c0_ = cell_of((X_), (INV_CELL_));                                                 \
        for (int dz_ = -1; dz_ <= 1; ++dz_)                                                            \
            for (int dy_ = -1; dy_ <= 1; ++dy_)                                                        \
                for (int dx_ = -1; dx_ <= 1; ++dx_) {                                                  \
                    int3 c_ = c0_ + (int3)(dx_, dy_, dz_);                                             \
                    if (!key_in_range(c_)) continue;                                                   \
                    long s_ = hash_find((KEYS_), (MASK_), pack_key(c_));                          \
                    if (s_ < 0) continue;                                                              \
                    uint2 r_ = (RANGE_)[s_];                                                            \
                    for (uint j = r_.x; j < r_.x + r_.y; ++j) {                                        \
                        float4 pj = (SORTED_)[j];                                                       \
                        BODY                                                                           \
                    }                                                                                  \
                }                                                                                      \
    }
