// Stage 2 (DESIGN §3.1, Müller et al. 2003): colour field gradient per particle with poly6
// weights -> surface particles and normals; fewer than SPLASH_NEIGHBOURS neighbours -> splash.
// Runs over the binned (sorted) particles; outputs are in sorted order.
// Build options: SURFACE_GRADIENT, SPLASH_NEIGHBOURS, THIN_NEIGHBOURS.

#define FLAG_SURFACE 1
#define FLAG_SPLASH 2
#define FLAG_THIN 4   /* fewer than THIN_NEIGHBOURS neighbours: a small cluster, filament or sheet */

// Each work-group takes `per_group` occupied bins in turn (launching a work-group costs more than
// a bin's work on CPU devices); a bin's particles share the 27 bins around it as candidates,
// gathered once into local memory (same neighbour order as the global loop, see gather_candidates).
__kernel void color_field(__global const float4* sorted, __global const uint* occupied, uint occupied_count,
                          uint per_group, float inv_cell,
                          __global const ulong* bin_keys, ulong bin_mask, __global const uint2* range, float R,
                          float volume, __global float4* gradient, __global uchar* flags, __local float4* cand,
                          __local uint* bin_first, __local uint* bin_slot, __local uint* count) {
  const uint first_bin = get_group_id(0) * per_group;
  for (uint ob = first_bin; ob < min(first_bin + per_group, occupied_count); ++ob) {
    barrier(CLK_LOCAL_MEM_FENCE);  // the previous bin is done with the candidates
    const uint2 own = range[occupied[ob]];
    const int3 bin = cell_of(sorted[own.x], inv_cell);
    const uint n_cand = gather_candidates(bin - 1, bin + 1, sorted, bin_keys, bin_mask, range, cand, bin_first,
                                          bin_slot, count);
    const float R2 = R * R;
    const float grad_norm = -945.0f / (32.0f * M_PI_F * pown(R, 9)) * volume;
    for (uint k = get_local_id(0); k < own.y; k += get_local_size(0)) {
        const uint i = own.x + k;
        const float4 xi = sorted[i];
        float3 g = (float3)(0.0f);
        int neighbours = 0;
#define ACCUMULATE(pj)                                    \
        {                                                 \
            float3 d = xi.xyz - (pj).xyz;                 \
            float d2 = dot(d, d);                         \
            if (d2 < R2 && as_uint((pj).w) != i) {        \
                float q = R2 - d2;                        \
                g += grad_norm * q * q * d;               \
                ++neighbours;                             \
            }                                             \
        }
        if (n_cand <= MAX_CANDIDATES) {
            for (uint j = 0; j < n_cand; ++j) ACCUMULATE(cand[j])
        } else {
            FOR_EACH_NEIGHBOUR_BIN(xi, inv_cell, bin_keys, bin_mask, range, sorted, ACCUMULATE(pj))
        }
#undef ACCUMULATE
        uchar f = 0;
        if (length(g) * R > SURFACE_GRADIENT) f |= FLAG_SURFACE;
        if (neighbours < SPLASH_NEIGHBOURS) f |= FLAG_SPLASH | FLAG_SURFACE;
        if (neighbours < THIN_NEIGHBOURS) f |= FLAG_THIN;
        gradient[i] = (float4)(g, (float)neighbours);
        flags[i] = f;
    }
  }
}
