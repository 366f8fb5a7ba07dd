// Lock-free open-addressing hash of 64-bit keys (docs/design.md §5): any capacity that is a multiple of
// 8 (so a table need not round up to a power of two: the fine-point table is most of the peak
// memory), linear probing, insert-only, empty slot = all ones. Keys are lattice points or cells packed 20 bits
// per axis (src/core/lattice.hpp). A probe longer than the capacity reports overflow (-1); the host
// then grows the table and reruns the stage, so nothing is silently dropped. No work-item ever
// waits for another (PoCL runs a work-group as a loop).
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable
// Uses: nothing before it but contract.h (FINE_KEY_BITS comes as a build option).

#define EMPTY_KEY 0xffffffffffffffffUL
#define AXIS_BITS 20
#define AXIS_MASK 0xfffffUL

// Hash of a key, identical to trilevel::lattice::hash(); home_slot() maps it into a table. Keys come in
// blocks of 2x2x2 whose eight members share one run of 8 slots (one cache line of keys): the
// block goes through the splitmix64 finaliser, the key's place in it fills the low 3 bits. Points
// with all coordinates even (the level-2 lattice) form blocks of their own on that lattice, so
// the 27 points of a level-2 cell are 8 lines of the fine-point table, and a level-3 cell's 125
// about 35, instead of one random line each. Particle bins, counting-sort buckets in slot order,
// come out spatially grouped. Blocks of 4x4x4 made probe runs 7x longer for no gain. Results
// never depend on slots, only on keys (docs/design.md §6).
#define LOWEST_BITS (1UL | (1UL << AXIS_BITS) | (1UL << (2 * AXIS_BITS)))
inline ulong trilevel_hash(ulong k) {
    const int even = (k & LOWEST_BITS) == 0;
    if (even) k = (k >> 1) | (1UL << 63);  // halves every coordinate (their lowest bits are 0)
    const ulong in_block = (k & 1UL) | ((k >> (AXIS_BITS - 1)) & 2UL) | ((k >> (2 * AXIS_BITS - 2)) & 4UL);
    k &= ~LOWEST_BITS;
    k ^= k >> 30;
    k *= 0xbf58476d1ce4e5b9UL;
    k ^= k >> 27;
    k *= 0x94d049bb133111ebUL;
    k ^= k >> 31;
    return (k << 3) | in_block;
}

// Home slot of a key in a table of `capacity` slots (a multiple of 8, below 2^35), identical to
// trilevel::lattice::home_slot(). A power-of-two table takes the hash's low bits. Any other size
// (the fine-point table, sized to what it holds) takes the block's run of 8 by multiply-shift: the
// top 32 bits of the hash times the number of runs, shifted down 32 (a 32x32-bit product, which
// vectorises where a 64-bit mul_hi does not); the key's place in its block fills the low 3 bits.
// The particle bins keep the low-bit layout: their counting-sort buckets run in slot order, and
// particle_curvature ran slower on the multiply-shift order (bench/RESULTS-implementation.md).
inline ulong slot_of_hash(ulong h, ulong capacity) {
    if ((capacity & (capacity - 1)) == 0) return h & (capacity - 1);
    return ((((h >> 32) * (capacity >> 3)) >> 32) << 3) | (h & 7UL);
}
inline ulong home_slot(ulong k, ulong capacity) { return slot_of_hash(trilevel_hash(k), capacity); }

inline ulong next_slot(ulong s, ulong capacity) { return s + 1 == capacity ? 0 : s + 1; }

inline ulong pack_key(int3 p) {
    return (ulong)(uint)p.x | ((ulong)(uint)p.y << AXIS_BITS) | ((ulong)(uint)p.z << (2 * AXIS_BITS));
}

inline int3 unpack_key(ulong k) {
    return (int3)((int)(k & AXIS_MASK), (int)((k >> AXIS_BITS) & AXIS_MASK),
                  (int)((k >> (2 * AXIS_BITS)) & AXIS_MASK));
}

inline int key_in_range(int3 p) {
    return p.x >= 0 && p.y >= 0 && p.z >= 0 && p.x <= (int)AXIS_MASK && p.y <= (int)AXIS_MASK &&
           p.z <= (int)AXIS_MASK;
}

// Returns the slot of `key`, or -1 when absent.
inline long hash_find(const __global ulong* keys, ulong capacity, ulong key) {
    ulong s = home_slot(key, capacity);
    for (ulong i = 0; i < capacity; ++i) {
        ulong cur = keys[s];
        if (cur == key) return (long)s;
        if (cur == EMPTY_KEY) return -1;
        s = next_slot(s, capacity);
    }
    return -1;
}

// Inserts `key` and returns its slot, or -1 when the table is full or already overflowed
// (stats[0], looked at every 32 probes: probes that long mean a full table, where every key still
// to come would scan all of it before the host could grow it, quadratic in the keys).
// *created tells whether this call put the key there.
inline long hash_insert(volatile __global ulong* keys, ulong capacity, ulong key, int* created,
                        volatile __global const int* stats) {
    ulong s = home_slot(key, capacity);
    *created = 0;
    for (ulong i = 0; i < capacity; ++i) {
        if ((i & 31) == 31 && stats[0]) return -1;
        ulong cur = keys[s];
        if (cur == key) return (long)s;
        if (cur == EMPTY_KEY) {
            ulong prev = atom_cmpxchg(&keys[s], EMPTY_KEY, key);
            if (prev == EMPTY_KEY) { *created = 1; return (long)s; }
            if (prev == key) return (long)s;
        }
        s = next_slot(s, capacity);
    }
    return -1;
}

// The counters a table keeps through its inserts: stats[0] = overflow flag, stats[1] = keys newly
// inserted (the host grows the table when it passes its load limit: 1/2, fine points 0.85).
// The counters' side of an insert that returned slot `s` (-1: full) and `created`; the flag also
// goes up when the keys pass `overflow_at`.
inline long count_insert(long s, int created, volatile __global int* stats, ulong overflow_at) {
    if (created && (ulong)atomic_inc(&stats[1]) >= overflow_at) atomic_or(&stats[0], 1);
    if (s < 0) atomic_or(&stats[0], 1);
    return s;
}

// hash_insert with the counters. Past half the table's slots it raises the overflow flag too: the
// host grows a table that holds more than that anyway (needs_growth), and the keys still to come
// then stop at their 32nd probe instead of filling the table to its last slot. Particles far apart
// for their radius need up to 27 coarse cells each where the table was sized for 0.75: 64 k of
// them took 38 s in mark_surface_cells, each key scanning a full table.
inline long hash_insert_counted(volatile __global ulong* keys, ulong capacity, ulong key, volatile __global int* stats) {
    int created;
    const long s = hash_insert(keys, capacity, key, &created, stats);
    return count_insert(s, created, stats, capacity / 2);
}

// The fine-point table stores lattice point p as fine_key(p): its coordinates packed with the
// frame's shifts (y from bit shift.x, z from bit shift.y) into FINE_KEY_BITS bits, 32 when the
// lattice fits (src/core/lattice.hpp, KeyLayout), else 64. Its home slot is always that of pack_key(p),
// so the table's layout does not depend on the storage.
#if FINE_KEY_BITS == 32
typedef uint fine_key_t;
#define FINE_EMPTY 0xffffffffu
#define fine_cmpxchg atomic_cmpxchg
#else
typedef ulong fine_key_t;
#define FINE_EMPTY EMPTY_KEY
#define fine_cmpxchg atom_cmpxchg
#endif

inline fine_key_t fine_key(int3 p, uint2 shift) {
    return (fine_key_t)(uint)p.x | ((fine_key_t)(uint)p.y << shift.x) | ((fine_key_t)(uint)p.z << shift.y);
}

inline int3 fine_point(fine_key_t k, uint2 shift) {
    const fine_key_t one = 1;
    return (int3)((int)(k & ((one << shift.x) - one)), (int)((k >> shift.x) & ((one << (shift.y - shift.x)) - one)),
                  (int)(k >> shift.y));
}

// fine_find from a home slot the caller computed (a block's members share their hash but for the
// low 3 bits: see trilevel_hash).
inline long fine_find_from(const __global fine_key_t* keys, ulong capacity, ulong s, int3 p, uint2 shift) {
    const fine_key_t key = fine_key(p, shift);
    for (ulong i = 0; i < capacity; ++i) {
        const fine_key_t cur = keys[s];
        if (cur == key) return (long)s;
        if (cur == FINE_EMPTY) return -1;
        s = next_slot(s, capacity);
    }
    return -1;
}

// hash_find for lattice point p in the fine-point table.
inline long fine_find(const __global fine_key_t* keys, ulong capacity, int3 p, uint2 shift) {
    return fine_find_from(keys, capacity, home_slot(pack_key(p), capacity), p, shift);
}

// hash_insert for lattice point p in the fine-point table.
inline long fine_insert(volatile __global fine_key_t* keys, ulong capacity, int3 p, uint2 shift, int* created) {
    const fine_key_t key = fine_key(p, shift);
    ulong s = home_slot(pack_key(p), capacity);
    *created = 0;
    for (ulong i = 0; i < capacity; ++i) {
        const fine_key_t cur = keys[s];
        if (cur == key) return (long)s;
        if (cur == FINE_EMPTY) {
            const fine_key_t prev = fine_cmpxchg(&keys[s], FINE_EMPTY, key);
            if (prev == FINE_EMPTY) { *created = 1; return (long)s; }
            if (prev == key) return (long)s;
        }
        s = next_slot(s, capacity);
    }
    return -1;
}

// fine_insert with the counters. No early overflow: the fine-point table is sized for the points
// before they are inserted (ensure_fine_room).
inline long fine_insert_counted(volatile __global fine_key_t* keys, ulong capacity, int3 p, uint2 shift,
                                volatile __global int* stats) {
    int created;
    const long s = fine_insert(keys, capacity, p, shift, &created);
    return count_insert(s, created, stats, ULONG_MAX);
}

// Moves every point (and its value) of an old fine-point table into a larger one.
__kernel void fine_rehash(__global const fine_key_t* old_keys, __global const float* old_values, ulong old_capacity,
                          volatile __global fine_key_t* keys, __global float* values, ulong capacity, uint2 shift,
                          volatile __global int* stats) {
    ulong i = get_global_id(0);
    if (i >= old_capacity) return;
    const fine_key_t k = old_keys[i];
    if (k == FINE_EMPTY) return;
    long s = fine_insert_counted(keys, capacity, fine_point(k, shift), shift, stats);
    if (s >= 0) values[s] = old_values[i];
}
