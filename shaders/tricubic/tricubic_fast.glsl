// Tricubic B-spline evaluation from trilinear texture fetches (Sigg & Hadwiger, GPU Gems 2
// ch. 20; Cabral 2010 listing 5.2 interpolate_tricubic_fast), extended to first and second
// derivatives. The sampler MUST filter linearly (vgraph.gl.volume_rendering.linear_sampler).
//
// Along one axis a cubic B-spline sum w0 c[b-1] + w1 c[b] + w2 c[b+1] + w3 c[b+2] is two linear
// interpolations when each pair of weights has one sign: with g0 = w0 + w1, g1 = w2 + w3,
//   sum = g0 L(b - 1 + w1 / g0) + g1 L(b + 1 + w3 / g1),   L = linear interpolation of c,
// and the tensor product of three such 2-tap filters is 2 x 2 x 2 = 8 trilinear fetches.
// - order 0 (B3): all weights >= 0, g0, g1 >= 1/6: Sigg & Hadwiger's form.
// - order 1 (B3'): w0, w1 <= 0 and w2, w3 >= 0, so each pair still has one sign; the pair sums
//   are g1 = 0.5 + t - t^2 >= 0.5 and g0 = -g1, so f' = g1 (L(h1) - L(h0)): a difference of two
//   fetches with the same kind of offsets.
// - order 2 (B3''): the weights (1 - t, 3t - 2, 1 - 3t, t) change sign inside the pairs (g0 = 2t - 1
//   vanishes at t = 1/2), but B3'' is the second difference of the linear B-spline, so
//   f'' = L(u - 1) - 2 L(u) + L(u + 1): three fetches with fixed weights and no division.
// Fetches per result: value 8, each first derivative 8, f_xy-type 8, f_xx-type 12:
// value 8, + gradient 32, + Hessian 92 (the direct form needs 64 for all of them).
//
// Boundary: every fetch position is folded by whole-sample mirroring before it is turned into a
// texture coordinate (bspline_mirror_coordinate), which is exactly the CPU reference's mirrored
// coefficients; the folded coordinates stay within the voxel centres, so the texture's wrap mode
// (and GL_MIRRORED_REPEAT's edge duplication) never comes into play.
//
// Precision: the result inherits the texture unit's interpolation precision. llvmpipe filters
// float textures with float32 weights; many GPUs quantise the fractional weights to 8 bits,
// which limits this variant to roughly 1e-3 of the data's variation per voxel (docs/explanations/tricubic.md).
//
// Input and output conventions are those of tricubic_direct.glsl (voxel coordinates in, value
// and per-voxel derivatives out).
#include "bspline_weights.glsl"

// The linear fetches of one axis for one derivative order: texture coordinates and weights of up
// to three fetches (count of them used).
struct TricubicTaps {
    vec3 coord;
    vec3 weight;
    int count;
};

// Taps along one axis for voxel coordinate u on an axis of n voxels, derivative order 0, 1 or 2.
TricubicTaps tricubic_fast_taps(float u, int n, int order) {
    TricubicTaps taps;
    vec3 position;
    float base = floor(u);
    float t = u - base;
    if (order == 0) {
        vec4 w = bspline_weights(t);
        float g0 = w.x + w.y;
        float g1 = w.z + w.w;
        position = vec3(base - 1.0 + w.y / g0, base + 1.0 + w.w / g1, 0.0);
        taps.weight = vec3(g0, g1, 0.0);
        taps.count = 2;
    } else if (order == 1) {
        vec4 w = bspline_weights_d1(t);
        float g1 = w.z + w.w;  // = -(w.x + w.y)
        position = vec3(base - 1.0 + w.y / (w.x + w.y), base + 1.0 + w.w / g1, 0.0);
        taps.weight = vec3(-g1, g1, 0.0);
        taps.count = 2;
    } else {
        position = vec3(u - 1.0, u, u + 1.0);
        taps.weight = vec3(1.0, -2.0, 1.0);
        taps.count = 3;
    }
    float inv_n = 1.0 / float(n);
    for (int i = 0; i < 3; ++i) {
        taps.coord[i] = (bspline_mirror_coordinate(position[i], n) + 0.5) * inv_n;
    }
    return taps;
}

// sum over the taps of weight_x * weight_y * weight_z * trilinear fetch, contracted along x first.
float tricubic_fast_sum(sampler3D coeffs, TricubicTaps x, TricubicTaps y, TricubicTaps z) {
    float total = 0.0;
    for (int k = 0; k < z.count; ++k) {
        float plane = 0.0;
        for (int j = 0; j < y.count; ++j) {
            float row = 0.0;
            for (int i = 0; i < x.count; ++i) {
                // explicit LOD: the fetch may sit in non-uniform control flow
                row += x.weight[i] * textureLod(coeffs, vec3(x.coord[i], y.coord[j], z.coord[k]), 0.0).r;
            }
            plane += y.weight[j] * row;
        }
        total += z.weight[k] * plane;
    }
    return total;
}

// Value only: 8 fetches.
float tricubic_fast_value_voxel(sampler3D coeffs, vec3 p) {
    ivec3 n = textureSize(coeffs, 0);
    return tricubic_fast_sum(coeffs, tricubic_fast_taps(p.x, n.x, 0), tricubic_fast_taps(p.y, n.y, 0),
                             tricubic_fast_taps(p.z, n.z, 0));
}

// Value and gradient (per voxel): 32 fetches.
void tricubic_fast_gradient_voxel(sampler3D coeffs, vec3 p, out float value, out vec3 gradient) {
    ivec3 n = textureSize(coeffs, 0);
    TricubicTaps x0 = tricubic_fast_taps(p.x, n.x, 0), x1 = tricubic_fast_taps(p.x, n.x, 1);
    TricubicTaps y0 = tricubic_fast_taps(p.y, n.y, 0), y1 = tricubic_fast_taps(p.y, n.y, 1);
    TricubicTaps z0 = tricubic_fast_taps(p.z, n.z, 0), z1 = tricubic_fast_taps(p.z, n.z, 1);
    value = tricubic_fast_sum(coeffs, x0, y0, z0);
    gradient = vec3(tricubic_fast_sum(coeffs, x1, y0, z0), tricubic_fast_sum(coeffs, x0, y1, z0),
                    tricubic_fast_sum(coeffs, x0, y0, z1));
}

// Value, gradient and Hessian (per voxel): 92 fetches.
void tricubic_fast_jet_voxel(sampler3D coeffs, vec3 p, out float value, out vec3 gradient,
                             out mat3 hessian) {
    ivec3 n = textureSize(coeffs, 0);
    TricubicTaps x0 = tricubic_fast_taps(p.x, n.x, 0), x1 = tricubic_fast_taps(p.x, n.x, 1),
                 x2 = tricubic_fast_taps(p.x, n.x, 2);
    TricubicTaps y0 = tricubic_fast_taps(p.y, n.y, 0), y1 = tricubic_fast_taps(p.y, n.y, 1),
                 y2 = tricubic_fast_taps(p.y, n.y, 2);
    TricubicTaps z0 = tricubic_fast_taps(p.z, n.z, 0), z1 = tricubic_fast_taps(p.z, n.z, 1),
                 z2 = tricubic_fast_taps(p.z, n.z, 2);
    value = tricubic_fast_sum(coeffs, x0, y0, z0);
    gradient = vec3(tricubic_fast_sum(coeffs, x1, y0, z0), tricubic_fast_sum(coeffs, x0, y1, z0),
                    tricubic_fast_sum(coeffs, x0, y0, z1));
    float xy = tricubic_fast_sum(coeffs, x1, y1, z0);
    float xz = tricubic_fast_sum(coeffs, x1, y0, z1);
    float yz = tricubic_fast_sum(coeffs, x0, y1, z1);
    hessian = mat3(tricubic_fast_sum(coeffs, x2, y0, z0), xy, xz,
                   xy, tricubic_fast_sum(coeffs, x0, y2, z0), yz,
                   xz, yz, tricubic_fast_sum(coeffs, x0, y0, z2));
}
