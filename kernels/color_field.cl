// Stage 2 (docs/design.md §3.1, Müller et al. 2003): colour field gradient per particle with poly6
// weights -> surface particles and normals; fewer than SPLASH_NEIGHBOURS neighbours -> splash.
// Runs over the binned (sorted) particles; outputs are in sorted order. Gradients are packed xyz
// triples (3 floats a particle, not a float4): at 17.7 M particles the array is the largest one
// alive in stages 2 and 4 after the positions.
// Build options: SURFACE_GRADIENT, SPLASH_NEIGHBOURS, THIN_NEIGHBOURS, SAME_SPOT.
// A neighbour closer than SAME_SPOT * R is the same spot, not a neighbour, for the splash and thin
// counts: particles stacked on one point have no colour-field gradient at all, so without this a
// pile of them would be neither surface nor splash and vanish from the mesh. A pile spread a little
// (its neighbours within R / 4 of it in the root mean square, PILE_FRACTION) has next to no
// gradient either: it is splash too.
// Uses: contract.h (FLAG_*), hash_table.cl, particle_binning.cl (gather_candidates, bin_ranges, FOR_EACH_NEIGHBOUR_BIN).

// Writes FLAG_SURFACE, FLAG_SPLASH and FLAG_THIN (contract.h) per particle.

// Colour-field gradient and neighbour count of particle i over the 27 bins around it in global
// memory: for bins whose candidates do not fit in local memory.
inline void color_field_global(uint i, __global const float* sorted, float inv_cell, __global const ulong* bin_keys,
                               ulong bin_capacity, __global const uint2* range, float R2, float grad_norm,
                               float3* g_out, int* n_out, float* closeness_out) {
    const float4 xi = candidate(sorted, i);
    const float same2 = R2 * (SAME_SPOT * SAME_SPOT);
    float3 g = (float3)(0.0f);
    int neighbours = 0;
    float closeness = 0.0f;  // sum of R^2 - d^2 over the particle itself and its neighbours, in candidate order
    FOR_EACH_NEIGHBOUR_BIN(xi, inv_cell, bin_keys, bin_capacity, range, sorted, {
        float3 d = xi.xyz - pj.xyz;
        float d2 = dot(d, d);
        if (d2 < R2) {
            float q = R2 - d2;
            closeness += q;
            if (j != i) {
                g += grad_norm * q * q * d;
                if (d2 > same2) ++neighbours;
            }
        }
    })
    *g_out = g;
    *n_out = neighbours;
    *closeness_out = closeness;
}

// Splash: few neighbours, or a pile: `closeness`, the sum of R^2 - d^2 over the particle and its
// neighbours within R, is what neighbours + 1 points within R / 4 of it in the root mean square
// would give at least (the same-spot ones only add to it). Thin: few neighbours (a small cluster
// or a filament), or no gradient and fewer than sheet_limit (a sheet one particle thick:
// constants::kSheetNeighbourFraction).
inline uchar particle_flags(float3 g, int neighbours, float closeness, float R, float sheet_limit) {
    uchar f = 0;
    const float pile = (float)(neighbours + 1) * (1.0f - PILE_FRACTION * PILE_FRACTION) * (R * R);
    if (length(g) * R > SURFACE_GRADIENT) f |= FLAG_SURFACE;
    if (neighbours < SPLASH_NEIGHBOURS || closeness >= pile) f |= FLAG_SPLASH | FLAG_SURFACE;
    if (neighbours < THIN_NEIGHBOURS || (!(f & FLAG_SURFACE) && (float)neighbours < sheet_limit)) f |= FLAG_THIN;
    return f;
}

// The colour-field gradients and flags of `n` particles from sorted index `first_particle`, N at
// once from work-item `lid` on, one per vector lane (spare lanes repeat the last particle), over
// the candidates in local memory, bin b of the box from bin_first[b] in z, y, x order. N = 8: one
// bin's particles over the 3 x 3 x 3 bins around it. N = 16: a bin's n_first particles and its +x
// neighbour's, over the 4 x 3 x 3 bins around both; each lane then masks the column of bins
// beyond its own 27, so its sums, in candidate order, are those of color_field_global either way.
// Two sources of candidates (SOURCE): SERIAL_GATHER reads them in place, bin b from
// sorted[bin_first[b]] on, bin_count[b] of them (bin_ranges); otherwise from the list in local
// memory that gather_candidates made, bin b from cand[bin_first[b]] to the next bin's first.
#if SERIAL_GATHER
#define COLOR_CANDIDATES __global const float* cand
#define COLOR_CANDIDATE(j) ((float4)(vload3((j), cand), 0.0f))
#define COLOR_BIN_END(b) (bin_first[b] + bin_count[b])
#else
#define COLOR_CANDIDATES __local const float4* cand
#define COLOR_CANDIDATE(j) (cand[j])
#define COLOR_BIN_END(b) ((b) + 1 < 9 * width ? bin_first[(b) + 1] : n_cand)
#endif
#define DEFINE_COLOR_BATCHES(N)                                                                                       \
    inline void color_batches##N(uint first_particle, uint n, uint n_first, __global const float* sorted,             \
                                 COLOR_CANDIDATES, __local const uint* bin_first, __local const uint* bin_count,      \
                                 uint n_cand, float R, float R2, float same2, float grad_norm,                        \
                                 float sheet_limit,                                                                   \
                                 __global float* gradient, __global uchar* flags) {                                   \
        const int width = N == 16 ? 4 : 3, paired = N == 16;                                                           \
        const uint lid = get_local_id(0), lsize = get_local_size(0);                                                  \
        for (uint first = lid * N; first < n; first += lsize * N) {                                                   \
            float px[N], py[N], pz[N];                                                                                 \
            int column[N];                                                                                             \
            for (int l = 0; l < N; ++l) {                                                                              \
                const uint k = min(first + l, n - 1);                                                                  \
                const float3 x = vload3(first_particle + k, sorted);                                                   \
                px[l] = x.x; py[l] = x.y; pz[l] = x.z;                                                                 \
                column[l] = k < n_first ? 1 : 2;                                                                       \
            }                                                                                                          \
            const float##N X = vload##N(0, px), Y = vload##N(0, py), Z = vload##N(0, pz);                              \
            const int##N C = vload##N(0, column);                                                                      \
            float##N gx = 0.0f, gy = 0.0f, gz = 0.0f;                                                                  \
            int##N nb = 0;                                                                                             \
            float##N closeness = 0.0f; /* the particle itself is a candidate: it adds R^2 */                        \
            for (int b = 0; b < 9 * width; ++b) {                                                                      \
                const int col = b % width;                                                                             \
                /* lanes whose 27 bins hold this one: all of them for one bin (a constant the loop drops) */          \
                const int##N near = paired ? (C - 1 <= col) & (col <= C + 1) : (int##N)(-1);                           \
                const uint end = COLOR_BIN_END(b);                                                                     \
                for (uint j = bin_first[b]; j < end; ++j) {                                                            \
                    const float4 pj = COLOR_CANDIDATE(j);                                                              \
                    const float##N dx = X - pj.x, dy = Y - pj.y, dz = Z - pj.z;                                        \
                    const float##N d2 = dx * dx + dy * dy + dz * dz;                                                   \
                    const int##N in = (d2 < R2) & near; /* the particle itself too: it adds 0 * w, no neighbour */    \
                    const float##N q = select((float##N)(0.0f), R2 - d2, in);                                          \
                    const float##N w = grad_norm * q * q;                                                              \
                    gx += w * dx; gy += w * dy; gz += w * dz;                                                          \
                    nb -= in & (d2 > same2); /* true is -1 */                                                          \
                    closeness += q;                                                                                    \
                }                                                                                                      \
            }                                                                                                          \
            float ox[N], oy[N], oz[N];                                                                                 \
            int on[N];                                                                                                 \
            float oq[N];                                                                                               \
            vstore##N(gx, 0, ox); vstore##N(gy, 0, oy); vstore##N(gz, 0, oz); vstore##N(nb, 0, on);                  \
            vstore##N(closeness, 0, oq);                                                                               \
            for (uint l = 0; l < N && first + l < n; ++l) {                                                            \
                const float3 g = (float3)(ox[l], oy[l], oz[l]);                                                        \
                vstore3(g, first_particle + first + l, gradient);                                                      \
                flags[first_particle + first + l] = particle_flags(g, on[l], oq[l], R, sheet_limit);                   \
            }                                                                                                          \
        }                                                                                                              \
    }
DEFINE_COLOR_BATCHES(8)
#if VECTOR_WIDTH == 16
DEFINE_COLOR_BATCHES(16)
#endif

// Each work-group takes `per_group` occupied bins in turn (launching a work-group costs more than
// a bin's work on CPU devices); a bin's particles share the 27 bins around it as candidates, eight
// particles a work-item: read in place on CPU devices (bin_ranges: copying them to local memory
// there was a tenth of the kernel), else gathered once into local memory (gather_candidates).
// Where vectors are 16 wide (VECTOR_WIDTH), a bin and the next one when it is its +x neighbour
// go together: their 16 particles or so fill one vector, over the 4 x 3 x 3 bins around both (a
// third more candidates for twice the particles). A particle's sums do not change: each lane skips the
// column of bins beyond its own 27, and those keep their order in the larger box. Bins whose
// candidates do not fit local memory use color_field_global.
__kernel void color_field(__global const float* sorted, __global const uint* occupied, uint occupied_count,
                          uint per_group, float inv_cell,
                          __global const ulong* bin_keys, ulong bin_capacity, __global const uint2* range, float R,
                          float volume, float sheet_limit, __global float* gradient, __global uchar* flags, __local float4* cand,
                          __local uint* bin_first, __local uint* bin_slot, __local uint* count) {
    const float R2 = R * R, same2 = R2 * (SAME_SPOT * SAME_SPOT);
    const float grad_norm = -945.0f / (32.0f * M_PI_F * pown(R, 9)) * volume;
    const uint lid = get_local_id(0), lsize = get_local_size(0);
    const uint first_bin = get_group_id(0) * per_group, end = min(first_bin + per_group, occupied_count);
    for (uint ob = first_bin; ob < end;) {
        barrier(CLK_LOCAL_MEM_FENCE);  // the previous bin is done with the candidates
        const uint2 own = range[occupied[ob]];
        const int3 bin = cell_of(vload3(own.x, sorted), inv_cell);
        bool pair = false;
        uint n = own.y;
#if VECTOR_WIDTH == 16
        if (ob + 1 < end) {  // ranges follow the occupied order, so the pair's particles are contiguous
            const uint2 next = range[occupied[ob + 1]];
            pair = all(cell_of(vload3(next.x, sorted), inv_cell) == bin + (int3)(1, 0, 0)) && next.x == own.x + own.y;
            if (pair) n += next.y;
        }
#endif
        ob += pair ? 2 : 1;
        const int3 blo = bin - 1, bhi = bin + (int3)(pair ? 2 : 1, 1, 1);
#if SERIAL_GATHER
        bin_ranges(blo, bhi, bin_keys, bin_capacity, range, bin_first, bin_slot);  // bin_slot: the bins' counts
        const uint n_cand = 0;  // unused: the candidates stay in place, however many
        __global const float* const source = sorted;
#else
        const uint n_cand = gather_candidates(blo, bhi, sorted, bin_keys, bin_capacity, range, cand, bin_first, bin_slot,
                                              count);
        __local const float4* const source = cand;
#endif
        if (n_cand > MAX_CANDIDATES) {
            for (uint k = lid; k < n; k += lsize) {
                float3 g;
                int nb;
                float closeness;
                color_field_global(own.x + k, sorted, inv_cell, bin_keys, bin_capacity, range, R2, grad_norm, &g, &nb, &closeness);
                vstore3(g, own.x + k, gradient);
                flags[own.x + k] = particle_flags(g, nb, closeness, R, sheet_limit);
            }
            continue;
        }
#if VECTOR_WIDTH == 16
        if (pair) {
            color_batches16(own.x, n, own.y, sorted, source, bin_first, bin_slot, n_cand, R, R2, same2, grad_norm, sheet_limit,
                            gradient, flags);
            continue;
        }
#endif
        color_batches8(own.x, n, n, sorted, source, bin_first, bin_slot, n_cand, R, R2, same2, grad_norm, sheet_limit, gradient,
                       flags);
    }
}
