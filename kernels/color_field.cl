// Stage 2 (docs/design.md §3.1, Müller et al. 2003): colour field gradient per particle with poly6
// weights -> surface particles and normals; fewer than SPLASH_NEIGHBOURS neighbours -> splash.
// Runs over the binned (sorted) particles; outputs are in sorted order. Gradients are packed xyz
// triples (3 floats a particle, not a float4): at 17.7 M particles the array is the largest one
// alive in stages 2 and 4 after the positions.
// Build options: SURFACE_GRADIENT, SPLASH_NEIGHBOURS, THIN_NEIGHBOURS, SAME_SPOT.
// A neighbour closer than SAME_SPOT * R is the same spot, not a neighbour, for the splash and thin
// counts: particles stacked on one point have no colour-field gradient at all, so without this a
// pile of them would be neither surface nor splash and vanish from the mesh.
// Uses: contract.h (FLAG_*), hash_table.cl, particle_binning.cl (gather_candidates, FOR_EACH_NEIGHBOUR_BIN).

// Writes FLAG_SURFACE, FLAG_SPLASH and FLAG_THIN (contract.h) per particle.

// Colour-field gradient and neighbour count of particle i over the 27 bins around it in global
// memory: for bins whose candidates do not fit in local memory.
inline void color_field_global(uint i, __global const float* sorted, float inv_cell, __global const ulong* bin_keys,
                               ulong bin_capacity, __global const uint2* range, float R2, float grad_norm,
                               float3* g_out, int* n_out) {
    const float4 xi = candidate(sorted, i);
    const float same2 = R2 * (SAME_SPOT * SAME_SPOT);
    float3 g = (float3)(0.0f);
    int neighbours = 0;
    FOR_EACH_NEIGHBOUR_BIN(xi, inv_cell, bin_keys, bin_capacity, range, sorted, {
        float3 d = xi.xyz - pj.xyz;
        float d2 = dot(d, d);
        if (d2 < R2 && j != i) {
            float q = R2 - d2;
            g += grad_norm * q * q * d;
            if (d2 > same2) ++neighbours;
        }
    })
    *g_out = g;
    *n_out = neighbours;
}

inline uchar particle_flags(float3 g, int neighbours, float R) {
    uchar f = 0;
    if (length(g) * R > SURFACE_GRADIENT) f |= FLAG_SURFACE;
    if (neighbours < SPLASH_NEIGHBOURS) f |= FLAG_SPLASH | FLAG_SURFACE;
    if (neighbours < THIN_NEIGHBOURS) f |= FLAG_THIN;
    return f;
}

// Each work-group takes `per_group` occupied bins in turn (launching a work-group costs more than
// a bin's work on CPU devices); a bin's particles share the 27 bins around it as candidates,
// gathered once into local memory (gather_candidates). A work-item takes 8 particles at once, one
// per vector lane; each lane adds its neighbours in candidate order, so a particle's result does
// not depend on its lane. Bins whose candidates do not fit use color_field_global.
__kernel void color_field(__global const float* sorted, __global const uint* occupied, uint occupied_count,
                          uint per_group, float inv_cell,
                          __global const ulong* bin_keys, ulong bin_capacity, __global const uint2* range, float R,
                          float volume, __global float* gradient, __global uchar* flags, __local float4* cand,
                          __local uint* bin_first, __local uint* bin_slot, __local uint* count) {
    const float R2 = R * R, same2 = R2 * (SAME_SPOT * SAME_SPOT);
    const float grad_norm = -945.0f / (32.0f * M_PI_F * pown(R, 9)) * volume;
    const uint lid = get_local_id(0), lsize = get_local_size(0);
    const uint first_bin = get_group_id(0) * per_group;
    for (uint ob = first_bin; ob < min(first_bin + per_group, occupied_count); ++ob) {
        barrier(CLK_LOCAL_MEM_FENCE);  // the previous bin is done with the candidates
        const uint2 own = range[occupied[ob]];
        const int3 bin = cell_of(vload3(own.x, sorted), inv_cell);
        const uint n_cand = gather_candidates(bin - 1, bin + 1, sorted, bin_keys, bin_capacity, range, cand, bin_first,
                                              bin_slot, count);
        if (n_cand > MAX_CANDIDATES) {
            for (uint k = lid; k < own.y; k += lsize) {
                float3 g;
                int nb;
                color_field_global(own.x + k, sorted, inv_cell, bin_keys, bin_capacity, range, R2, grad_norm, &g, &nb);
                vstore3(g, own.x + k, gradient);
                flags[own.x + k] = particle_flags(g, nb, R);
            }
            continue;
        }
        for (uint first = lid * 8; first < own.y; first += lsize * 8) {
            float px[8], py[8], pz[8];
            for (int l = 0; l < 8; ++l) {  // spare lanes repeat the last particle
                const uint i = own.x + min(first + l, own.y - 1);
                const float3 x = vload3(i, sorted);
                px[l] = x.x; py[l] = x.y; pz[l] = x.z;
            }
            const float8 X = vload8(0, px), Y = vload8(0, py), Z = vload8(0, pz);
            float8 gx = 0.0f, gy = 0.0f, gz = 0.0f;
            int8 nb = 0;
            for (uint j = 0; j < n_cand; ++j) {
                const float4 pj = cand[j];
                const float8 dx = X - pj.x, dy = Y - pj.y, dz = Z - pj.z;
                const float8 d2 = dx * dx + dy * dy + dz * dz;
                const int8 in = d2 < R2;  // the particle itself too: it adds 0 * w and is no neighbour (d2 = 0)
                const float8 q = select((float8)(0.0f), R2 - d2, in);
                const float8 w = grad_norm * q * q;
                gx += w * dx; gy += w * dy; gz += w * dz;
                nb -= in & (d2 > same2);  // true is -1
            }
            float ox[8], oy[8], oz[8];
            int on[8];
            vstore8(gx, 0, ox); vstore8(gy, 0, oy); vstore8(gz, 0, oz); vstore8(nb, 0, on);
            for (uint l = 0; l < 8 && first + l < own.y; ++l) {
                const float3 g = (float3)(ox[l], oy[l], oz[l]);
                vstore3(g, own.x + first + l, gradient);
                flags[own.x + first + l] = particle_flags(g, on[l], R);
            }
        }
    }
}
