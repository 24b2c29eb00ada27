// The curvature measure shown (exactly one CURVATURE_* define) from a pixel of the curvature
// image, c = (k1, k2, K, flag): k1, k2, GAUSSIAN K = k1 k2, MEAN H = (k1 + k2) / 2, CURVEDNESS
// sqrt((k1^2 + k2^2) / 2), SHAPE_INDEX (2/pi) atan2(k1 + k2, k1 - k2) in [-1, 1], as
// vgraph.numerics.curvature computes them.
// Zero curvature: |k| <= zero_curvature (1e-3 per voxel of the smallest spacing, a radius of
// curvature over 1000 voxels) reads as 0, |K| <= zero_curvature^2 likewise, and the shape index is
// 0 where the curvedness is (atan2(0, 0) is undefined). Float rounding and the filters leave
// noise far below this on flat surfaces (~1e-5 per voxel); without the floor the linear
// normalisation would stretch that noise over the whole colour map and the zero contour would
// speckle. The curvature output keeps the unfloored values.
uniform float zero_curvature;  // 1/world units

float floored(float value, float floor_value) {
    return abs(value) <= floor_value ? 0.0 : value;
}

float curvature_measure(vec4 c) {
#if defined(CURVATURE_K1)
    return floored(c.x, zero_curvature);
#elif defined(CURVATURE_K2)
    return floored(c.y, zero_curvature);
#elif defined(CURVATURE_GAUSSIAN)
    return floored(c.z, zero_curvature * zero_curvature);
#elif defined(CURVATURE_MEAN)
    return floored(0.5 * (c.x + c.y), zero_curvature);
#elif defined(CURVATURE_CURVEDNESS)
    return floored(sqrt(0.5 * (c.x * c.x + c.y * c.y)), zero_curvature);
#else  // CURVATURE_SHAPE_INDEX
    float sum = c.x + c.y;
    float difference = c.x - c.y;  // >= 0: k1 >= k2
    bool is_flat = sqrt(0.5 * (c.x * c.x + c.y * c.y)) <= zero_curvature;
    return is_flat ? 0.0 : 0.63661977236758134 * atan(sum, difference);
#endif
}
