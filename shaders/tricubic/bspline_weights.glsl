// Cubic B-spline weights and whole-sample mirroring, shared by both tricubic variants.
//
// Conventions (the same as the CPU reference vgraph.numerics.bspline):
// - Voxel coordinates: voxel i of an axis sits at u = i; texture coordinate (i + 0.5) / n.
// - A point u = floor(u) + t (t in [0, 1)) is reconstructed from the four coefficients at
//   indices floor(u) - 1, floor(u), floor(u) + 1, floor(u) + 2; component k of the vec4 returned
//   by bspline_weights*() weighs coefficient floor(u) - 1 + k (numerics.bspline.bspline_weights).
// - Boundary: whole-sample mirror (scipy mode 'mirror'), c[-k] = c[k], c[n-1+k] = c[n-1-k],
//   period 2n - 2. An axis of length 1 is constant.

// B3(t + 1), B3(t), B3(t - 1), B3(t - 2) (Cabral 2010 eq. 3.3). The middle two use the symmetric
// forms 2/3 - t^2 (2 - t) / 2, which lose less to rounding than the expanded cubic near t = 1.
vec4 bspline_weights(float t) {
    float s = 1.0 - t;
    return vec4(s * s * s, 4.0 - 3.0 * t * t * (2.0 - t), 4.0 - 3.0 * s * s * (2.0 - s),
                t * t * t) * (1.0 / 6.0);
}

// First derivatives B3'(t + 1), ..., B3'(t - 2) (seed eq. 3.5). The weights sum to 0; the first
// two are <= 0 and the last two >= 0 for t in [0, 1].
vec4 bspline_weights_d1(float t) {
    float s = 1.0 - t;
    return vec4(-0.5 * s * s, t * (1.5 * t - 2.0), s * (1.5 * t + 0.5), 0.5 * t * t);
}

// Second derivatives B3''(t + 1), ..., B3''(t - 2) (seed eq. 3.6): (1 - t, 3t - 2, 1 - 3t, t),
// i.e. the linear interpolation at t of the second differences c[i-1] - 2 c[i] + c[i+1].
vec4 bspline_weights_d2(float t) {
    return vec4(1.0 - t, 3.0 * t - 2.0, 1.0 - 3.0 * t, t);
}

// Fold integer indices into [0, n - 1] by whole-sample mirroring (period 2n - 2). GLSL's % is
// undefined for negative operands, so the index is first mirrored about 0 with abs(), which the
// even extension allows.
ivec4 bspline_mirror_index(ivec4 index, int n) {
    int last = n - 1;
    int period = max(2 * last, 1);  // n = 1: everything folds to 0
    ivec4 folded = abs(index) % period;
    return last - abs(folded - last);
}

// The same fold for a continuous voxel coordinate. The linear interpolant of the mirrored
// coefficients is the mirrored linear interpolant (the fold bends only at integer coordinates),
// so a linear texture fetch at the folded coordinate equals the fetch the mirrored texture would
// give. Exact (no rounding) for u in [0, n - 1], where mod() returns u itself.
float bspline_mirror_coordinate(float u, int n) {
    if (n < 2) {
        return 0.0;
    }
    float last = float(n - 1);
    float folded = mod(abs(u), 2.0 * last);
    return last - abs(folded - last);
}
