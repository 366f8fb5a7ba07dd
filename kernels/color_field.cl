// Stage 2 (DESIGN §3.1, Müller et al. 2003): colour field gradient per particle with poly6
// weights -> surface particles and normals; fewer than SPLASH_NEIGHBOURS neighbours -> splash.
// Runs over the binned (sorted) particles; outputs are in sorted order.
// Build options: SURFACE_GRADIENT, SPLASH_NEIGHBOURS, THIN_NEIGHBOURS.

#define FLAG_SURFACE 1
#define FLAG_SPLASH 2
#define FLAG_THIN 4   /* fewer than THIN_NEIGHBOURS neighbours: a small cluster, filament or sheet */

__kernel void color_field(__global const float4* sorted, uint n, float inv_cell,
                          __global const ulong* bin_keys, ulong bin_mask, __global const uint2* range,
                          float R, float volume, __global float4* gradient, __global uchar* flags) {
    uint i = get_global_id(0);
    if (i >= n) return;
    float4 xi = sorted[i];
    float R2 = R * R;
    float grad_norm = -945.0f / (32.0f * M_PI_F * pown(R, 9)) * volume;
    float3 g = (float3)(0.0f);
    int neighbours = 0;
    FOR_EACH_NEIGHBOUR_BIN(xi, inv_cell, bin_keys, bin_mask, range, sorted, {
        float3 d = xi.xyz - pj.xyz;
        float d2 = dot(d, d);
        if (d2 < R2 && j != i) {
            float q = R2 - d2;
            g += grad_norm * q * q * d;
            ++neighbours;
        }
    })
    uchar f = 0;
    if (length(g) * R > SURFACE_GRADIENT) f |= FLAG_SURFACE;
    if (neighbours < SPLASH_NEIGHBOURS) f |= FLAG_SPLASH | FLAG_SURFACE;
    if (neighbours < THIN_NEIGHBOURS) f |= FLAG_THIN;
    gradient[i] = (float4)(g, (float)neighbours);
    flags[i] = f;
}
