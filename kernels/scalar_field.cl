// Stage 6 (DESIGN §3.3; Solenthaler, Schläfli, Pajarola 2007 after Zhu & Bridson 2005): the signed
// distance phi at every pending fine lattice point. Inside the fluid where phi < 0.
//   k_j = (1 - s_j^2)^3, s_j = |x - x_j| / R;  xbar = sum k_j x_j / K;
//   phi = |x - xbar| - r f(EVmax), EVmax = largest real part of the eigenvalues of J = d xbar / dx.
// Sums use y_j = x_j - x (translation invariant, better float precision):
//   J = (sum y_j (x) grad k_j - ybar (x) sum grad k_j) / K,  grad k_j = -6 (1 - s_j^2)^2 (x - x_j) / R^2.
// Build options: EV_LOW, EV_HIGH.

// Largest real part of the eigenvalues of a 3x3 matrix (rows a, b, c) from its characteristic
// polynomial l^3 - t l^2 + m l - d (t: trace, m: sum of principal 2x2 minors, d: determinant),
// solved in closed form: three real roots by the trigonometric method, else one real root and a
// complex pair whose real part is -t1/2 in the depressed variable. Tested against QR iterations
// in src/reference (tests/test_kernels_vs_reference.cpp).
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

inline float solenthaler_f(float ev) {
    if (ev < EV_LOW) return 1.0f;
    if (ev > EV_HIGH) return 0.0f;
    float g = (EV_HIGH - ev) / (EV_HIGH - EV_LOW);
    return g * g * g - 3.0f * g * g + 3.0f * g;
}

__kernel void scalar_field(__global const uint* pending, uint count, __global const ulong* keys,
                           __global float* values, float step, __global const float4* sorted, float inv_cell,
                           __global const ulong* bin_keys, ulong bin_mask, __global const uint2* range,
                           float r, float R) {
    uint i = get_global_id(0);
    if (i >= count) return;
    uint slot = pending[i];
    float4 x = (float4)(convert_float3(unpack_key(keys[slot])) * step, 0.0f);
    float R2 = R * R, inv_R2 = 1.0f / R2;
    float K = 0.0f;
    float3 S = (float3)(0.0f), G = (float3)(0.0f);
    float3 A0 = (float3)(0.0f), A1 = (float3)(0.0f), A2 = (float3)(0.0f);  // rows of sum y (x) grad k
    FOR_EACH_NEIGHBOUR_BIN(x, inv_cell, bin_keys, bin_mask, range, sorted, {
        float3 y = pj.xyz - x.xyz;
        float d2 = dot(y, y);
        if (d2 < R2) {
            float q = 1.0f - d2 * inv_R2;
            float k = q * q * q;
            float3 gk = (6.0f * q * q * inv_R2) * y;  // -6 q^2 (x - x_j) / R^2
            K += k;
            S += k * y;
            G += gk;
            A0 += y.x * gk;
            A1 += y.y * gk;
            A2 += y.z * gk;
        }
    })
    if (K <= 0.0f) { values[slot] = R; return; }
    float3 ybar = S / K;
    float inv_K = 1.0f / K;
    float ev = largest_real_eigenvalue((A0 - ybar.x * G) * inv_K, (A1 - ybar.y * G) * inv_K,
                                       (A2 - ybar.z * G) * inv_K);
    values[slot] = length(ybar) - r * solenthaler_f(ev);
}
