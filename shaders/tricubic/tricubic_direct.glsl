// Tricubic B-spline evaluation by the direct sum (Cabral 2010 eq. 3.10, listing 5.2
// interpolate_tricubic): f(p) = sum c[k, j, i] B3(x - i) B3(y - j) B3(z - k) over the 4 x 4 x 4
// coefficients around p, read with texelFetch (no filtering, so the filter state of the sampler
// is irrelevant) and weighted in float32. Derivatives replace B3 by B3' or B3'' in the factor of
// the differentiated axis; all partial derivatives come from the same 64 fetches.
//
// Input: p in voxel coordinates (x, y, z): voxel (i, j, k) at p = (i, j, k). Output: value in the
// coefficients' units, derivatives per voxel (d/du); hessian[a][b] = d2f / du_a du_b (symmetric,
// so GL's column-major order does not matter). Indices outside the grid are mirrored like the CPU
// reference, so the result matches numerics.bspline.evaluate everywhere, also outside the grid.
#include "bspline_weights.glsl"

// The 64 coefficient indices around p: per axis, the mirrored indices floor(p) - 1 .. floor(p) + 2,
// and the fractional position t = p - floor(p).
void tricubic_direct_stencil(sampler3D coeffs, vec3 p, out ivec4 ix, out ivec4 iy, out ivec4 iz,
                             out vec3 t) {
    ivec3 n = textureSize(coeffs, 0);
    vec3 base = floor(p);
    t = p - base;
    ivec3 b = ivec3(base);
    ivec4 offsets = ivec4(-1, 0, 1, 2);
    ix = bspline_mirror_index(b.x + offsets, n.x);
    iy = bspline_mirror_index(b.y + offsets, n.y);
    iz = bspline_mirror_index(b.z + offsets, n.z);
}

// Four coefficients along x at row (j, k) of the stencil.
vec4 tricubic_direct_row(sampler3D coeffs, ivec4 ix, int j, int k) {
    return vec4(texelFetch(coeffs, ivec3(ix.x, j, k), 0).r, texelFetch(coeffs, ivec3(ix.y, j, k), 0).r,
                texelFetch(coeffs, ivec3(ix.z, j, k), 0).r, texelFetch(coeffs, ivec3(ix.w, j, k), 0).r);
}

// Value only: 64 fetches.
float tricubic_direct_value_voxel(sampler3D coeffs, vec3 p) {
    ivec4 ix, iy, iz;
    vec3 t;
    tricubic_direct_stencil(coeffs, p, ix, iy, iz, t);
    vec4 wx = bspline_weights(t.x), wy = bspline_weights(t.y), wz = bspline_weights(t.z);
    float value = 0.0;
    for (int k = 0; k < 4; ++k) {
        float plane = 0.0;
        for (int j = 0; j < 4; ++j) {
            plane += wy[j] * dot(tricubic_direct_row(coeffs, ix, iy[j], iz[k]), wx);
        }
        value += wz[k] * plane;
    }
    return value;
}

// Value and gradient (per voxel): 64 fetches. Contraction order x, then y, then z; the vec2s hold
// (order 0, order 1) of the axes contracted so far.
void tricubic_direct_gradient_voxel(sampler3D coeffs, vec3 p, out float value, out vec3 gradient) {
    ivec4 ix, iy, iz;
    vec3 t;
    tricubic_direct_stencil(coeffs, p, ix, iy, iz, t);
    vec4 wx0 = bspline_weights(t.x), wy0 = bspline_weights(t.y), wz0 = bspline_weights(t.z);
    vec4 wx1 = bspline_weights_d1(t.x), wy1 = bspline_weights_d1(t.y), wz1 = bspline_weights_d1(t.z);
    vec2 a0 = vec2(0.0);  // (f, df/dx)
    float a1 = 0.0;       // df/dy
    float b0 = 0.0;       // df/dz
    for (int k = 0; k < 4; ++k) {
        vec2 y0 = vec2(0.0);  // sum over j of B(y) * (row . wx0, row . wx1)
        float y1 = 0.0;       // sum over j of B'(y) * (row . wx0)
        for (int j = 0; j < 4; ++j) {
            vec4 row = tricubic_direct_row(coeffs, ix, iy[j], iz[k]);
            vec2 x = vec2(dot(row, wx0), dot(row, wx1));
            y0 += wy0[j] * x;
            y1 += wy1[j] * x.x;
        }
        a0 += wz0[k] * y0;
        a1 += wz0[k] * y1;
        b0 += wz1[k] * y0.x;
    }
    value = a0.x;
    gradient = vec3(a0.y, a1, b0);
}

// Value, gradient and Hessian (per voxel): 64 fetches. Vector components index the derivative
// order of the axes already contracted (x first, then y).
void tricubic_direct_jet_voxel(sampler3D coeffs, vec3 p, out float value, out vec3 gradient,
                               out mat3 hessian) {
    ivec4 ix, iy, iz;
    vec3 t;
    tricubic_direct_stencil(coeffs, p, ix, iy, iz, t);
    vec4 wx0 = bspline_weights(t.x), wy0 = bspline_weights(t.y), wz0 = bspline_weights(t.z);
    vec4 wx1 = bspline_weights_d1(t.x), wy1 = bspline_weights_d1(t.y), wz1 = bspline_weights_d1(t.z);
    vec4 wx2 = bspline_weights_d2(t.x), wy2 = bspline_weights_d2(t.y), wz2 = bspline_weights_d2(t.z);
    vec3 z0y0 = vec3(0.0);  // (f, f_x, f_xx)
    vec2 z0y1 = vec2(0.0);  // (f_y, f_xy)
    float z0y2 = 0.0;       // f_yy
    vec2 z1y0 = vec2(0.0);  // (f_z, f_xz)
    float z1y1 = 0.0;       // f_yz
    float z2y0 = 0.0;       // f_zz
    for (int k = 0; k < 4; ++k) {
        vec3 y0 = vec3(0.0);  // x orders 0, 1, 2 under B(y)
        vec2 y1 = vec2(0.0);  // x orders 0, 1 under B'(y)
        float y2 = 0.0;       // x order 0 under B''(y)
        for (int j = 0; j < 4; ++j) {
            vec4 row = tricubic_direct_row(coeffs, ix, iy[j], iz[k]);
            vec3 x = vec3(dot(row, wx0), dot(row, wx1), dot(row, wx2));
            y0 += wy0[j] * x;
            y1 += wy1[j] * x.xy;
            y2 += wy2[j] * x.x;
        }
        z0y0 += wz0[k] * y0;
        z0y1 += wz0[k] * y1;
        z0y2 += wz0[k] * y2;
        z1y0 += wz1[k] * y0.xy;
        z1y1 += wz1[k] * y1.x;
        z2y0 += wz2[k] * y0.x;
    }
    value = z0y0.x;
    gradient = vec3(z0y0.y, z0y1.x, z1y0.x);
    hessian = mat3(z0y0.z, z0y1.y, z1y0.y,
                   z0y1.y, z0y2, z1y1,
                   z1y0.y, z1y1, z2y0);
}
