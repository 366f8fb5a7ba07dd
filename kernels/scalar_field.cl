// Stage 6 (docs/design.md §3.3; Solenthaler, Schläfli, Pajarola 2007 after Zhu & Bridson 2005): the signed
// distance phi at every pending fine lattice point. Inside the fluid where phi < 0.
//   k_j = (1 - s_j^2)^3, s_j = |x - x_j| / R;  xbar = sum k_j x_j / K;
//   phi = |x - xbar| - r f(EVmax), EVmax = largest real part of the eigenvalues of J = d xbar / dx.
// Sums use y_j = x_j - x (translation invariant, better float precision):
//   J = (sum y_j (x) grad k_j - ybar (x) sum grad k_j) / K,  grad k_j = -6 (1 - s_j^2)^2 (x - x_j) / R^2.
// Build options: EV_LOW, EV_HIGH, VECTOR_WIDTH (8 or 16: points a work-item evaluates at once).
// Uses: contract.h (CLAIM_*, MAX_CELL_POINTS), hash_table.cl, particle_binning.cl (FOR_EACH_NEIGHBOUR_BIN, candidate),
// refine_points.cl (cell_level, cell_has_point).

// Largest real part of the eigenvalues of a 3x3 matrix (rows a, b, c) from its characteristic
// polynomial l^3 - t l^2 + m l - d (t: trace, m: sum of principal 2x2 minors, d: determinant),
// solved in closed form: three real roots by the trigonometric method, else one real root and a
// complex pair whose real part is -t1/2 in the depressed variable. Tested against QR iterations
// in tests/reference (through the field in tests/test_device_stages.cpp; the host copy in
// tests/test_vertex_data.cpp).
inline float largest_real_eigenvalue(float3 a, float3 b, float3 c) {
    float t = a.x + b.y + c.z;
    float m = (a.x * b.y - a.y * b.x) + (a.x * c.z - a.z * c.x) + (b.y * c.z - b.z * c.y);
    float d = dot(a, cross(b, c));
    // l = u + t/3:  u^3 + p u + q = 0
    float s = t / 3.0f;
    float p = m - t * s;
    float q = -d + m * s - 2.0f * s * s * s;
    float disc = 0.25f * q * q + p * p * p / 27.0f;
    if (disc <= 0.0f && p < 0.0f) {
        float rho = sqrt(-p / 3.0f);
        float arg = clamp(-q / (2.0f * rho * rho * rho), -1.0f, 1.0f);
        return 2.0f * rho * cos(acos(arg) / 3.0f) + s;
    }
    float sq = sqrt(max(disc, 0.0f));
    float u1 = cbrt(-0.5f * q + sq) + cbrt(-0.5f * q - sq);
    return max(u1, -0.5f * u1) + s;
}

// The points' vectors in scalar_field_cells: VECTOR_WIDTH lanes, one point each. 16 where the device
// prefers 16-wide float vectors (AVX-512 CPUs: a 16-wide FMA costs 1.25x an 8-wide one), else 8
// (GPUs, whose lanes are work-items: each vector lane is a register there).
#if VECTOR_WIDTH == 16
typedef float16 floatL;
typedef int16 intL;
#define vloadL vload16
#define vstoreL vstore16
#else
typedef float8 floatL;
typedef int8 intL;
#define vloadL vload8
#define vstoreL vstore8
#endif

// dot(a, cross(b, c)) per lane, rounded as the scalar builtins round it on PoCL (no contraction
// into fused multiply-adds), so that both kernels take the same branch of the closed form.
inline floatL triple_productL(floatL ax, floatL ay, floatL az, floatL bx, floatL by, floatL bz, floatL cx, floatL cy,
                              floatL cz) {
#pragma OPENCL FP_CONTRACT OFF
    const floatL kx = by * cz - bz * cy, ky = bz * cx - bx * cz, kz = bx * cy - by * cx;
    return ax * kx + ay * ky + az * kz;
}

// largest_real_eigenvalue for VECTOR_WIDTH matrices at once, one per vector lane (rows a, b, c by
// component), with the scalar function's expressions. Both closed forms are evaluated and each
// lane selects its own: vector acos, cos and cbrt cost far less than eight scalar calls. They round
// differently from the scalar forms now and then (docs/design.md, "Eigenvalues in vector form").
inline floatL largest_real_eigenvalueL(floatL ax, floatL ay, floatL az, floatL bx, floatL by, floatL bz, floatL cx,
                                       floatL cy, floatL cz) {
    const floatL t = ax + by + cz;
    const floatL m = (ax * by - ay * bx) + (ax * cz - az * cx) + (by * cz - bz * cy);
    const floatL d = triple_productL(ax, ay, az, bx, by, bz, cx, cy, cz);
    const floatL s = t / 3.0f;
    const floatL p = m - t * s;
    const floatL q = -d + m * s - 2.0f * s * s * s;
    const floatL disc = 0.25f * q * q + p * p * p / 27.0f;
    const intL three_real = (disc <= 0.0f) & (p < 0.0f);
    const floatL rho = sqrt(select((floatL)(1.0f), -p / 3.0f, three_real));
    const floatL arg = clamp(-q / (2.0f * rho * rho * rho), -1.0f, 1.0f);
    const floatL trig = 2.0f * rho * cos(acos(arg) / 3.0f) + s;
    const floatL sq = sqrt(max(disc, 0.0f));
    const floatL u1 = cbrt(-0.5f * q + sq) + cbrt(-0.5f * q - sq);
    return select(max(u1, -0.5f * u1) + s, trig, three_real);
}

// The least and greatest lane of a floatL, halving the vector each step.
inline float min8(float8 v) { const float4 a = fmin(v.lo, v.hi); const float2 b = fmin(a.lo, a.hi); return fmin(b.x, b.y); }
inline float max8(float8 v) { const float4 a = fmax(v.lo, v.hi); const float2 b = fmax(a.lo, a.hi); return fmax(b.x, b.y); }
#if VECTOR_WIDTH == 16
inline float min_lane(floatL v) { return min8(fmin(v.lo, v.hi)); }
inline float max_lane(floatL v) { return max8(fmax(v.lo, v.hi)); }
#else
inline float min_lane(floatL v) { return min8(v); }
inline float max_lane(floatL v) { return max8(v); }
#endif

inline float solenthaler_f(float ev) {
    if (ev < EV_LOW) return 1.0f;
    if (ev > EV_HIGH) return 0.0f;
    float g = (EV_HIGH - ev) / (EV_HIGH - EV_LOW);
    return g * g * g - 3.0f * g * g + 3.0f * g;
}

// phi from the neighbour sums: |ybar| - r f(EVmax), ybar = x-bar relative to the point; +R without
// neighbours (K = 0).
inline float solenthaler_value(float K, float3 ybar, float ev, float r, float R) {
    return K <= 0.0f ? R : length(ybar) - r * solenthaler_f(ev);
}

inline float solenthaler_phi(float K, float3 S, float3 G, float3 A0, float3 A1, float3 A2, float r, float R) {
    if (K <= 0.0f) return R;
    float3 ybar = S / K;
    float inv_K = 1.0f / K;
    float ev = largest_real_eigenvalue((A0 - ybar.x * G) * inv_K, (A1 - ybar.y * G) * inv_K, (A2 - ybar.z * G) * inv_K);
    return solenthaler_value(K, ybar, ev, r, R);
}

__kernel void scalar_field(__global const uint* pending, uint count, __global const fine_key_t* keys,
                           __global float* values, float step, __global const float* sorted, float inv_cell,
                           __global const ulong* bin_keys, ulong bin_capacity, __global const uint2* range,
                           float r, float R, uint2 shift) {
    uint i = get_global_id(0);
    if (i >= count) return;
    uint slot = pending[i];
    float4 x = (float4)(convert_float3(fine_point(keys[slot], shift)) * step, 0.0f);
    float R2 = R * R, inv_R2 = 1.0f / R2;
    float K = 0.0f;
    float3 S = (float3)(0.0f), G = (float3)(0.0f);
    float3 A0 = (float3)(0.0f), A1 = (float3)(0.0f), A2 = (float3)(0.0f);  // rows of sum y (x) grad k
    FOR_EACH_NEIGHBOUR_BIN(x, inv_cell, bin_keys, bin_capacity, range, sorted, {
        float3 y = pj.xyz - x.xyz;
        float d2 = dot(y, y);
        float q = 1.0f - d2 * inv_R2;
        if (q > SUPPORT_CUT) {  // the support's cut rim (src/stage_constants.hpp)
            float k = q * q * q;
            float3 gk = ((6.0f * inv_R2) * q * q) * y;  // -6 q^2 (x - x_j) / R^2, rounded as in scalar_field_cells
            K += k;
            S += k * y;
            G += gk;
            A0 += y.x * gk;
            A1 += y.y * gk;
            A2 += y.z * gk;
        }
    })
    values[slot] = solenthaler_phi(K, S, G, A0, A1, A2, r, R);
}

// Candidate particles of one coarse cell gathered into local memory (paper Fig. 3: the particles
// that influence the cell's points lie within R of the cell box). A point shared by several cells
// is evaluated once: in the passes that insert (CLAIM_INSERTED, the main pass, and CLAIM_REFINED_EDGES,
// edge refinement) by the work-group whose insert created it, which spares a separate insert
// pass and a second table lookup per point; in the other passes
// by the work-group that claims it first (its NaN "pending" value becomes CLAIMED). Each
// work-item then evaluates VECTOR_WIDTH claimed points at once, one per vector lane: every lane adds its
// neighbours in candidate order (bins in z, y, x order, each in index order), so a point's value
// does not depend on its lane or its partners. A cell whose candidates do not fit claims nothing
// (what it inserted stays pending) and raises `overflow`; the host then lets the other cells claim
// what is left and evaluates the rest with the per-point kernel above, so which kernel evaluates a
// point depends only on the cells, never on timing.
#define PENDING_BITS 0x7fc00000u
#define CLAIMED_BITS 0x7fc00001u
#define COLUMN_LANES 8  // candidates near_candidates tests at once
#define NOT_CLAIMED 0xffffffffu

// The candidates within R of the box around the points X, Y, Z, in candidate order, as
// indices into the candidate list. The others lie beyond every lane's support and would add exact
// zeros, so the sums keep their bits; sorting them out costs a few operations per candidate
// against some forty vector ones, and a branch-free loop (a skip inside the sum loop mispredicts
// about as often as it saves). Points in lattice order span about a 4r x r slab: a third of the
// 27 bins' candidates remain. Eight candidates are tested at once, one per lane, from the
// candidates' coordinates in columns (cx, cy, cz: padded to a multiple of 8 with far points).
inline uint near_candidates(floatL X, floatL Y, floatL Z, __local const float* cx, __local const float* cy,
                            __local const float* cz, uint n_cand, float R2, ushort* near) {
    const float lox = min_lane(X), loy = min_lane(Y), loz = min_lane(Z);
    const float hix = max_lane(X), hiy = max_lane(Y), hiz = max_lane(Z);
    const float keep2 = R2 * 1.0625f;  // a margin for rounding: a few extra zeros cost nothing
    uint n = 0;
    for (uint j = 0; j < n_cand; j += COLUMN_LANES) {  // float8: COLUMN_LANES is 8
        const float8 px = vload8(0, cx + j), py = vload8(0, cy + j), pz = vload8(0, cz + j);
        const float8 dx = fmax(fmax(lox - px, px - hix), 0.0f);
        const float8 dy = fmax(fmax(loy - py, py - hiy), 0.0f);
        const float8 dz = fmax(fmax(loz - pz, pz - hiz), 0.0f);
        const int8 keep = dx * dx + dy * dy + dz * dz <= keep2;  // true is -1
        near[n] = (ushort)j; n -= keep.s0;
        near[n] = (ushort)(j + 1); n -= keep.s1;
        near[n] = (ushort)(j + 2); n -= keep.s2;
        near[n] = (ushort)(j + 3); n -= keep.s3;
        near[n] = (ushort)(j + 4); n -= keep.s4;
        near[n] = (ushort)(j + 5); n -= keep.s5;
        near[n] = (ushort)(j + 6); n -= keep.s6;
        near[n] = (ushort)(j + 7); n -= keep.s7;
    }
    return n;
}

// The candidates of a cell's points (gather_candidates' bins and order: for any point inside, its
// neighbours in the order of FOR_EACH_NEIGHBOUR_BIN) straight into the columns that near_candidates
// and the sums read (x, y, z, each CANDIDATE_COLUMN long), padded to whole vectors with points
// beyond any support (at 1e18 in the frame's coordinates, which lie within 2^20 steps of the
// origin: their squared distance, about 1e36, is finite and far above R^2). One pass over the
// particles instead of a float4 list and its transposition (the gather and the transposition were
// a third of scalar_field_cells; one pass made the kernel 0.93x). The bins come from bin_ranges
// (`bin_start`, `bin_count`: MAX_BINS each). Returns the count, or MAX_CANDIDATES + 1 when they do
// not fit. All work-items call it; SERIAL_GATHER as in gather_candidates.
#define WHOLE_LANES(n) (((n) + COLUMN_LANES - 1) / COLUMN_LANES * COLUMN_LANES)
#define CANDIDATE_COLUMN WHOLE_LANES(MAX_CANDIDATES)  // each column's length (host: contract::candidate_column)
inline uint gather_columns(int3 blo, int3 bhi, __global const float* sorted, __global const ulong* bin_keys,
                           ulong bin_capacity, __global const uint2* range, __local float* columns,
                           __local uint* bin_start, __local uint* bin_count) {
    const uint lid = get_local_id(0), lsize = get_local_size(0);
    const int3 bn = bhi - blo + 1;
    const int nbins = bn.x * bn.y * bn.z;
    if (nbins > MAX_BINS) return MAX_CANDIDATES + 1;
    bin_ranges(blo, bhi, bin_keys, bin_capacity, range, bin_start, bin_count);
    uint n = 0;
    for (int b = 0; b < nbins; ++b) n += bin_count[b];
    if (n > MAX_CANDIDATES) return MAX_CANDIDATES + 1;
    // CPU devices: the first work-item copies it all (the others would walk every bin for about
    // one particle each); other devices: every work-item a share of each bin.
    const uint first = SERIAL_GATHER ? 0 : lid, stride = SERIAL_GATHER ? 1 : lsize;
    if (!SERIAL_GATHER || lid == 0)
        for (uint b = 0, to = 0; b < (uint)nbins; to += bin_count[b++])
            for (uint k = first; k < bin_count[b]; k += stride) {
                const float3 p = vload3(bin_start[b] + k, sorted);
                columns[to + k] = p.x;
                columns[CANDIDATE_COLUMN + to + k] = p.y;
                columns[2 * CANDIDATE_COLUMN + to + k] = p.z;
            }
    for (uint k = n + lid; k < WHOLE_LANES(n); k += lsize) {
        columns[k] = 1e18f;
        columns[CANDIDATE_COLUMN + k] = 1e18f;
        columns[2 * CANDIDATE_COLUMN + k] = 1e18f;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    return n;
}

// Which pending points of its cell a work-group claims: CLAIM_* in contract.h.

// Edge refinement (tests/reference/edge_refinement.hpp) for one level-2 cell: the midpoints of its level-2 edges
// whose ends the surface separates (phi < 0 at one end only), inserted; the slots of those this
// work-group created go into claimed[0 .. *claimed_count), in no particular order (a point's
// value does not depend on its lane or partners). `corner` holds the (cs/2 + 1)^3 level-2 values
// meanwhile. A midpoint already in the table (a level-3 cell's point) is not created, so it keeps
// its value; each crossed edge is created once, by whichever of its up to four cells gets there
// first, and the value does not depend on the cell that evaluates it.
inline void claim_refined_edges(int3 base, int cs, volatile __global fine_key_t* keys, ulong capacity,
                                    volatile __global uint* value_bits, uint2 shift, __local float* corner,
                                    __local uint* claimed, volatile __local uint* claimed_count,
                                    volatile __global int* table_stats) {
    const uint lid = get_local_id(0), lsize = get_local_size(0);
    const int m = cs / 2 + 1, mm = m * m;  // level-2 points per axis: at most 5, so at most 125 corners
    const ulong recip = lattice_reciprocal(m);
    // The corners by the 2x2x2 blocks of the level-2 lattice that share a hash (trilevel_hash): one
    // hash a block instead of one a corner (base is even: hlo are the corners' halved coordinates).
    const int3 hlo = base / 2, blo = hlo >> 1, nb = ((hlo + m - 1) >> 1) - blo + 1;
    for (int b = (int)lid; b < nb.x * nb.y * nb.z; b += (int)lsize) {
        const int3 block = blo + (int3)(b % nb.x, (b / nb.x) % nb.y, b / (nb.x * nb.y));
        const ulong h = trilevel_hash(pack_key(block * 4));  // its lowest member: in-block bits 0
        for (int k = 0; k < 8; ++k) {
            const int3 hp = block * 2 + (int3)(k & 1, (k >> 1) & 1, k >> 2);
            const int3 o = hp - hlo;
            if (any(o < 0) || any(o >= m)) continue;
            const long slot = fine_find_from((const __global fine_key_t*)keys, capacity, slot_of_hash(h | (ulong)k, capacity),
                                             hp * 2, shift);
            corner[o.x + m * o.y + mm * o.z] = slot < 0 ? as_float(PENDING_BITS) : as_float(value_bits[slot]);  // NaN: no crossing
        }
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    if (lid == 0) {
        // Corner l is bit l of two 64-bit words (x fastest): the corners with a value, those inside
        // (phi < 0), and those with a neighbour towards +x, +y, +z. An edge from corner l along an axis
        // of stride s crosses where both ends have values and one is inside: bit l of
        // valid & (valid >> s) & (inside ^ (inside >> s)) & has_next. A cell has about two.
        ulong valid[2] = {0, 0}, inside[2] = {0, 0}, next[3][2] = {{0, 0}, {0, 0}, {0, 0}};
        for (int l = 0, x = 0, y = 0, z = 0; l < mm * m; ++l) {
            const ulong bit = 1UL << (l & 63);
            const float v = corner[l];
            if (!isnan(v)) valid[l >> 6] |= bit;
            if (v < 0.0f) inside[l >> 6] |= bit;
            if (x < m - 1) next[0][l >> 6] |= bit;
            if (y < m - 1) next[1][l >> 6] |= bit;
            if (z < m - 1) next[2][l >> 6] |= bit;
            if (++x == m) { x = 0; if (++y == m) { y = 0; ++z; } }
        }
        for (int axis = 0; axis < 3; ++axis) {
            const int s = axis == 0 ? 1 : axis == 1 ? m : mm;  // below 64
            const int3 d = (int3)(axis == 0, axis == 1, axis == 2);
            for (int w = 0; w < 2; ++w) {
                // the words shifted right by s across the pair
                const ulong vs = (valid[w] >> s) | (w == 0 ? valid[1] << (64 - s) : 0UL);
                const ulong is = (inside[w] >> s) | (w == 0 ? inside[1] << (64 - s) : 0UL);
                ulong cross = valid[w] & vs & (inside[w] ^ is) & next[axis][w];
                while (cross) {
                    const int l = 64 * w + (63 - (int)clz(cross & (0UL - cross)));  // lowest set bit
                    cross &= cross - 1;
                    const int3 o = lattice_offset(l, m, recip);
                    int created;
                    const long slot = fine_insert(keys, capacity, base + 2 * o + d, shift, &created);
                    if (slot < 0) atomic_or(&table_stats[0], 1);  // full: the host grows it and runs the pass again
                    if (created) claimed[(*claimed_count)++] = (uint)slot;
                }
            }
        }
    }
}

// Whether a cell above this one (towards +x, +y or +z, in the same list: w's CELL_ABOVE bits) also
// holds the point at local offset o (odd coordinates: `odd`; `last` = the cell's last offset). Such
// a point is inserted by a cell above, so that a point on the faces between cells is attempted
// about once instead of by each of its 2 to 8 cells: among the cells holding it, those with no
// holder above them insert it (at least one: the relation only goes up), and inserting is
// idempotent, so the table ends with the same points. Level 2 holds the even points only.
inline bool held_above(int w, int3 o, int last, int odd) {
    const int up = (o.x == last) | ((o.y == last) << 1) | ((o.z == last) << 2);
    for (int d = 1; d < 8 && up; ++d) {
        if (d & ~up) continue;  // that cell does not hold the point
        const int bits = w >> (CELL_ABOVE_SHIFT + 2 * (d - 1));
        if ((bits & 1) && (odd == 0 || (bits & 2))) return true;
    }
    return false;
}

// Claim phase of scalar_field_cells: the points of cell c this work-group evaluates, by `claim`
// (CLAIM_* in contract.h), as table slots in claimed[0 .. *claimed_count) in lattice order. Returns
// false when the group evaluates nothing: its candidates do not fit (it raises `overflow`, and
// what it created stays pending for the claiming pass the host runs next). All work-items call it.
inline bool claim_cell_points(int4 c, int coarse_steps, int claim, bool fits, volatile __global fine_key_t* keys,
                              ulong capacity, volatile __global uint* value_bits, volatile __global int* overflow,
                              __local uint* claimed, __local uint* claimed_count, volatile __global int* table_stats,
                              uint2 shift) {
    const uint lid = get_local_id(0), lsize = get_local_size(0);
    const int side = coarse_steps + 1;
    // A level-2 cell's points (cell_has_point) are the m^3 even offsets and, with CELL_CUBE_CENTRES,
    // the (m - 1)^3 cube centres after them: walked directly rather than by testing every point of
    // the cell (27 and 8 of 125 at the default radius: the field pass 0.935x at x64).
    const bool level2 = cell_level(c.w) == 2 && claim != CLAIM_EDGE_MIDPOINTS;
    const int m = coarse_steps / 2 + 1, evens = m * m * m;
    const int points = !level2 ? side * side * side : evens + ((c.w & CELL_CUBE_CENTRES) ? (m - 1) * (m - 1) * (m - 1) : 0);
    const ulong recip = lattice_reciprocal(side), recip_even = lattice_reciprocal(m), recip_centre = lattice_reciprocal(m - 1);
    const bool creates = claim == CLAIM_INSERTED || claim == CLAIM_REFINED_EDGES;  // the points this group created
    if (!fits && !creates) {
        if (lid == 0) atomic_or(overflow, 1);
        return false;
    }
    if (lid == 0 && claim != CLAIM_REFINED_EDGES) *claimed_count = 0;  // CLAIM_INSERTED: first the count of points created
    barrier(CLK_LOCAL_MEM_FENCE);
    for (int l = (int)lid; l < points && claim != CLAIM_REFINED_EDGES; l += (int)lsize) {  // claim the cell's pending points
        if (fits) claimed[l] = NOT_CLAIMED;
        const int3 o = !level2 ? lattice_offset(l, side, recip)
                       : l < evens ? 2 * lattice_offset(l, m, recip_even)
                                   : 2 * lattice_offset(l - evens, m - 1, recip_centre) + 1;
        const int odd = (o.x & 1) + (o.y & 1) + (o.z & 1);
        const bool take = level2 || (claim == CLAIM_EDGE_MIDPOINTS ? odd == 1 : cell_has_point(c.w, odd));
        if (!take) continue;
        const int3 point = c.xyz * coarse_steps + o;
        if (claim == CLAIM_INSERTED) {  // a point is evaluated by the work-group that created it
            if (held_above(c.w, o, coarse_steps, odd)) continue;
            int created;
            const long slot = fine_insert(keys, capacity, point, shift, &created);
            if (slot < 0) atomic_or(&table_stats[0], 1);  // full: the host grows it and claims again
            if (!created) continue;
            atomic_inc(claimed_count);
            if (fits) claimed[l] = (uint)slot;
            continue;
        }
        const long slot = fine_find((const __global fine_key_t*)keys, capacity, point, shift);
        if (slot < 0) continue;
        if (atomic_cmpxchg(&value_bits[slot], PENDING_BITS, CLAIMED_BITS) != PENDING_BITS) continue;
        claimed[l] = (uint)slot;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    if (lid == 0 && creates) atomic_add(&table_stats[1], (int)*claimed_count);  // once per group
    if (!fits) {  // its created points stay pending for the claiming pass the host runs next
        if (lid == 0) atomic_or(overflow, 1);
        return false;
    }
    if (lid == 0 && claim != CLAIM_REFINED_EDGES) {  // in lattice order, so that eight consecutive points lie close together
        uint n = 0;
        for (int l = 0; l < points; ++l)
            if (claimed[l] != NOT_CLAIMED) claimed[n++] = claimed[l];
        *claimed_count = n;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    return true;
}

// The field at the n_claimed points of `claimed` (table slots) from the n_cand candidates in the
// columns of gather_columns: each work-item takes VECTOR_WIDTH points at once, one per vector lane.
inline void evaluate_claimed(__local const uint* claimed, uint n_claimed, __local const float* columns, uint n_cand,
                             volatile __global fine_key_t* keys,
                             volatile __global uint* value_bits, float step, float r, float R, uint2 shift) {
    const uint lid = get_local_id(0), lsize = get_local_size(0);
    const float R2 = R * R, inv_R2 = 1.0f / R2;
    __local const float *cx = columns, *cy = columns + CANDIDATE_COLUMN, *cz = columns + 2 * CANDIDATE_COLUMN;
    ushort near[CANDIDATE_COLUMN];
    for (uint first = lid * VECTOR_WIDTH; first < n_claimed; first += lsize * VECTOR_WIDTH) {
        float px[VECTOR_WIDTH], py[VECTOR_WIDTH], pz[VECTOR_WIDTH];
        for (int l = 0; l < VECTOR_WIDTH; ++l) {  // spare lanes repeat the last point
            float3 x = convert_float3(fine_point(keys[claimed[min(first + l, n_claimed - 1)]], shift)) * step;
            px[l] = x.x; py[l] = x.y; pz[l] = x.z;
        }
        const floatL X = vloadL(0, px), Y = vloadL(0, py), Z = vloadL(0, pz);
        const uint n_near = near_candidates(X, Y, Z, cx, cy, cz, n_cand, R2, near);
        floatL K = 0.0f, Sx = 0.0f, Sy = 0.0f, Sz = 0.0f, Gx = 0.0f, Gy = 0.0f, Gz = 0.0f;
        floatL Axx = 0.0f, Axy = 0.0f, Axz = 0.0f, Ayx = 0.0f, Ayy = 0.0f, Ayz = 0.0f, Azx = 0.0f, Azy = 0.0f,
               Azz = 0.0f;
        for (uint j = 0; j < n_near; ++j) {
            const uint c = near[j];
            const floatL yx = cx[c] - X, yy = cy[c] - Y, yz = cz[c] - Z;
            const floatL d2 = yx * yx + yy * yy + yz * yz;
            const floatL q0 = 1.0f - d2 * inv_R2;
            const floatL q = select((floatL)(0.0f), q0, q0 > SUPPORT_CUT);  // 0 beyond the cut: adds nothing
            const floatL k = q * q * q;
            const floatL g = (6.0f * inv_R2) * q * q;
            const floatL gx = g * yx, gy = g * yy, gz = g * yz;
            K += k;
            Sx += k * yx; Sy += k * yy; Sz += k * yz;
            Gx += gx; Gy += gy; Gz += gz;
            Axx += yx * gx; Axy += yx * gy; Axz += yx * gz;
            Ayx += yy * gx; Ayy += yy * gy; Ayz += yy * gz;
            Azx += yz * gx; Azy += yz * gy; Azz += yz * gz;
        }
        // solenthaler_phi on all lanes at once, up to solenthaler_value
        const floatL bx = Sx / K, by = Sy / K, bz = Sz / K, inv_K = 1.0f / K;  // ybar = S / K
        const floatL ev = largest_real_eigenvalueL(
            (Axx - bx * Gx) * inv_K, (Axy - bx * Gy) * inv_K, (Axz - bx * Gz) * inv_K, (Ayx - by * Gx) * inv_K,
            (Ayy - by * Gy) * inv_K, (Ayz - by * Gz) * inv_K, (Azx - bz * Gx) * inv_K, (Azy - bz * Gy) * inv_K,
            (Azz - bz * Gz) * inv_K);
        float k_[VECTOR_WIDTH], ybx[VECTOR_WIDTH], yby[VECTOR_WIDTH], ybz[VECTOR_WIDTH], ev_[VECTOR_WIDTH];
        vstoreL(K, 0, k_); vstoreL(bx, 0, ybx); vstoreL(by, 0, yby); vstoreL(bz, 0, ybz); vstoreL(ev, 0, ev_);
        for (int l = 0; l < VECTOR_WIDTH && first + l < n_claimed; ++l) {
            const float phi = solenthaler_value(k_[l], (float3)(ybx[l], yby[l], ybz[l]), ev_[l], r, R);
            value_bits[claimed[first + l]] = as_uint(phi);
        }
    }
}

__kernel void scalar_field_cells(__global const int4* cells, int coarse_steps, int claim,
                                 volatile __global fine_key_t* keys, ulong capacity,
                                 volatile __global uint* value_bits, float step, __global const float* sorted,
                                 float inv_cell, __global const ulong* bin_keys, ulong bin_capacity,
                                 __global const uint2* range, float r, float R, volatile __global int* overflow,
                                 __local uint* bin_start, __local uint* bin_count, __local uint* claimed,
                                 __local uint* claimed_count,
                                 int cells_are_bins, volatile __global int* table_stats, uint2 shift,
                                 __local float* columns) {
    const int4 c = cells[get_group_id(0)];
    const uint lid = get_local_id(0);
    if (claim == CLAIM_REFINED_EDGES) {  // first the midpoints: a cell that creates none gathers nothing
        if (cell_level(c.w) != 2) return;
        if (lid == 0) *claimed_count = 0;
        barrier(CLK_LOCAL_MEM_FENCE);
        // The corners in the upper half of `claimed`, the created midpoints (at most 3 (cs/2) (cs/2 + 1)^2,
        // 300 for cs <= 8: the host checks) in its lower half.
        claim_refined_edges(c.xyz * coarse_steps, coarse_steps, keys, capacity, value_bits, shift,
                            (__local float*)(claimed + MAX_CELL_POINTS / 2), claimed, claimed_count, table_stats);
        barrier(CLK_LOCAL_MEM_FENCE);
        if (*claimed_count == 0) return;
    }
    // With the default kernel radius the coarse cells are the particle bins (edge R = 4r, one
    // origin): the particles inside the cut support of the cell's points are in the 27 bins around
    // it (SUPPORT_CUT). The float box below lands on bin faces there and took 4 or 5 bins per axis,
    // 2.5x the candidates; for other radii its extra bins only add zeros.
    int3 blo = c.xyz - 1, bhi = c.xyz + 1;
    if (!cells_are_bins) {
        blo = convert_int3_rtn((convert_float3(c.xyz * coarse_steps) * step - R) * inv_cell);
        bhi = convert_int3_rtn((convert_float3(c.xyz * coarse_steps + coarse_steps) * step + R) * inv_cell);
    }
    const uint n_cand = gather_columns(blo, bhi, sorted, bin_keys, bin_capacity, range, columns, bin_start, bin_count);
    const int side = coarse_steps + 1;
    const bool fits = n_cand <= MAX_CANDIDATES && side * side * side <= MAX_CELL_POINTS;
    if (!claim_cell_points(c, coarse_steps, claim, fits, keys, capacity, value_bits, overflow, claimed, claimed_count,
                           table_stats, shift))
        return;
    evaluate_claimed(claimed, *claimed_count, columns, n_cand, keys, value_bits, step, r, R, shift);
}
