// Positions in a caller's buffer (Reconstructor::reconstruct on DevicePositions): particle i's
// x, y, z are the floats at src[offset + i * stride] (offset and stride in floats). A program of
// its own, built on first use: the gather needs double precision, which the main program does not.

// The bounds of the positions, as the host's bounds_of computes them: work-item g takes particles
// g, g + G, g + 2G, ... (G work-items in all) and writes its lowest x, y, z, highest x, y, z and
// largest |coordinate| to partial[8g .. 8g + 6] (the host reduces them: min and max are exact in
// any order). The first particle with a non-finite coordinate lowers `bad` (set to n beforehand).
kernel void positions_bounds(global const float* src, ulong offset, ulong stride, uint n, global float* partial,
                             volatile global uint* bad) {
    const uint g = get_global_id(0), G = get_global_size(0);
    float3 lo = (float3)(INFINITY), hi = (float3)(-INFINITY);
    float far = 0.0f;
    for (uint i = g; i < n; i += G) {
        global const float* p = src + offset + (ulong)i * stride;
        const float3 v = (float3)(p[0], p[1], p[2]);
        if (!(isfinite(v.x) && isfinite(v.y) && isfinite(v.z))) {
            atomic_min(bad, i);  // this work-item's later particles come after it
            break;
        }
        lo = fmin(lo, v);
        hi = fmax(hi, v);
        far = fmax(far, fmax(fabs(v.x), fmax(fabs(v.y), fabs(v.z))));
    }
    global float* out = partial + 8 * (ulong)g;
    out[0] = lo.x, out[1] = lo.y, out[2] = lo.z;
    out[3] = hi.x, out[4] = hi.y, out[5] = hi.z;
    out[6] = far, out[7] = 0.0f;
}

#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
// The binning input, packed x, y, z relative to the lattice origin: float(double(x) - origin),
// exactly what the host upload computes (one correctly rounded subtraction and conversion each).
kernel void gather_positions(global const float* src, ulong offset, ulong stride, uint n, double ox, double oy,
                             double oz, global float* dst) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    global const float* p = src + offset + (ulong)i * stride;
    dst[3 * (ulong)i + 0] = (float)((double)p[0] - ox);
    dst[3 * (ulong)i + 1] = (float)((double)p[1] - oy);
    dst[3 * (ulong)i + 2] = (float)((double)p[2] - oz);
}
#endif
