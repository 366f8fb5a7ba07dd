// Stage 1 (docs/design.md §2): bin particles into a sparse grid of cell R by a stable counting sort.
// Positions are relative to the lattice origin (the host subtracts it in double precision), so
// cells are floor(p / cell) and far-from-origin scenes keep float precision.
// Occupied cells are keys in the lock-free hash; their slots serve as counting-sort buckets:
// count -> (host) exclusive scan -> scatter -> sort each bucket by particle index, so every
// neighbour sum later runs in the same order whatever the thread count (docs/design.md §6).
// Uses: contract.h (MAX_BINS), hash_table.cl (keys, hash_find); MAX_CANDIDATES and SERIAL_GATHER are build options.

inline int3 cell_of(float3 p, float inv_cell) {
    return convert_int3_rtn(p * inv_cell);
}

// Sorted particle j as a candidate: its position, and its sorted index in w (self-exclusion).
inline float4 candidate(__global const float* sorted, uint j) {
    return (float4)(vload3(j, sorted), as_float(j));
}

// `pos`: the input positions as packed xyz triples (3 floats a particle: at x512 a float4 array
// would add 70 MB at binning's peak, the gather).
__kernel void bin_insert(__global const float* pos, uint n, float inv_cell,
                         volatile __global ulong* keys, ulong capacity, __global int* slot_of,
                         volatile __global int* stats) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const int3 c = cell_of(vload3(i, pos), inv_cell);
    slot_of[i] = (int)hash_insert_counted(keys, capacity, pack_key(c), stats);
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

// Positions in bin order, packed xyz like the input (3 floats a particle: at x512 a float4 array
// would be 71 MB more); `candidate` adds the index when a gather copies one.
__kernel void bin_gather(__global const uint* order, uint n, __global const float* pos, __global float* sorted) {
    uint i = get_global_id(0);
    if (i >= n) return;
    vstore3(vload3(order[i], pos), i, sorted);
}

// Neighbour loop over the 27 bins around `x`; used by every particle and grid-point stage.
// BODY sees `float4 pj` and `uint j` (index into sorted arrays).
#define FOR_EACH_NEIGHBOUR_BIN(X_, INV_CELL_, KEYS_, CAPACITY_, RANGE_, SORTED_, BODY)              \
    {                                                                                                  \
        int3 c0_ = cell_of((X_).xyz, (INV_CELL_));                                               \
        for (int dz_ = -1; dz_ <= 1; ++dz_)                                                            \
            for (int dy_ = -1; dy_ <= 1; ++dy_)                                                        \
                for (int dx_ = -1; dx_ <= 1; ++dx_) {                                                  \
                    int3 c_ = c0_ + (int3)(dx_, dy_, dz_);                                             \
                    if (!key_in_range(c_)) continue;                                                   \
                    long s_ = hash_find((KEYS_), (CAPACITY_), pack_key(c_));                      \
                    if (s_ < 0) continue;                                                              \
                    uint2 r_ = (RANGE_)[s_];                                                            \
                    for (uint j = r_.x; j < r_.x + r_.y; ++j) {                                        \
                        float4 pj = candidate((SORTED_), j);                                                       \
                        BODY                                                                           \
                    }                                                                                  \
                }                                                                                      \
    }

// Work-group helper: gathers the particles of bins blo..bhi (inclusive) into local memory in
// z, y, x bin order, each bin in index order. For any point inside, its neighbours then appear in
// the same order as in FOR_EACH_NEIGHBOUR_BIN, so both paths give bit-identical sums. Returns
// the count, or MAX_CANDIDATES + 1 when they do not fit (the caller then loops over global memory).
// All work-items of the group must call it. SERIAL_GATHER (CPU devices, which run a work-group's
// items one after another): the first item copies while it looks the bins up, instead of every
// item walking all bins for a share of about one particle each.
// MAX_CANDIDATES comes from the host (OpenCLRuntime::max_candidates): as many as two float4 lists
// of them fit the device's local memory, at most 2048.
inline uint gather_candidates(int3 blo, int3 bhi, __global const float* sorted, __global const ulong* bin_keys,
                              ulong bin_capacity, __global const uint2* range, __local float4* cand,
                              __local uint* bin_first, __local uint* bin_slot, __local uint* count) {
    const uint lid = get_local_id(0), lsize = get_local_size(0);
    const int3 bn = bhi - blo + 1;
    const int nbins = bn.x * bn.y * bn.z;
    if (lid == 0) {
        uint total = 0;
        for (int b = 0; b < nbins && nbins <= MAX_BINS; ++b) {
            int3 q = blo + (int3)(b % bn.x, (b / bn.x) % bn.y, b / (bn.x * bn.y));
            long s = key_in_range(q) ? hash_find(bin_keys, bin_capacity, pack_key(q)) : -1;
            bin_slot[b] = (uint)s;
            bin_first[b] = total;
            if (s < 0) continue;
            const uint2 rg = range[s];
            if (SERIAL_GATHER && total + rg.y <= MAX_CANDIDATES)
                for (uint k = 0; k < rg.y; ++k) cand[total + k] = candidate(sorted, rg.x + k);
            total += rg.y;
        }
        *count = (nbins <= MAX_BINS && total <= MAX_CANDIDATES) ? total : MAX_CANDIDATES + 1;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    const uint n = *count;
    if (!SERIAL_GATHER && n <= MAX_CANDIDATES)
        for (int b = 0; b < nbins; ++b) {
            if ((int)bin_slot[b] < 0) continue;
            uint2 rg = range[bin_slot[b]];
            for (uint k = lid; k < rg.y; k += lsize) cand[bin_first[b] + k] = candidate(sorted, rg.x + k);
        }
    barrier(CLK_LOCAL_MEM_FENCE);
    return n;
}

// The ranges of bins blo..bhi (inclusive, at most MAX_BINS), in gather_candidates' z, y, x order:
// bin b holds sorted[first[b] .. first[b] + count[b]), count 0 for an empty bin. For the colour
// field reading its candidates in place (CPU devices: local memory is ordinary memory there, so a
// copy only costs) and the field kernel's gather (gather_columns). All work-items call it.
inline void bin_ranges(int3 blo, int3 bhi, __global const ulong* bin_keys, ulong bin_capacity,
                       __global const uint2* range, __local uint* first, __local uint* count) {
    if (get_local_id(0) == 0) {
        const int3 bn = bhi - blo + 1;
        int b = 0;
        for (int z = 0; z < bn.z; ++z)
            for (int y = 0; y < bn.y; ++y)
                for (int x = 0; x < bn.x; ++x, ++b) {
                    const int3 q = blo + (int3)(x, y, z);
                    const long s = key_in_range(q) ? hash_find(bin_keys, bin_capacity, pack_key(q)) : -1;
                    const uint2 rg = s < 0 ? (uint2)(0, 0) : range[s];
                    first[b] = rg.x;
                    count[b] = rg.y;
                }
    }
    barrier(CLK_LOCAL_MEM_FENCE);
}
