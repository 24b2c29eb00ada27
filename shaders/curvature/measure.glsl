// The curvature measure shown (exactly one CURVATURE_* define) from a pixel of the curvature
// image, c = (k1, k2, K, flag): k1, k2, GAUSSIAN K = k1 k2, MEAN H = (k1 + k2) / 2, CURVEDNESS
// sqrt((k1^2 + k2^2) / 2), SHAPE_INDEX (2/pi) atan2(k1 + k2, k1 - k2) in [-1, 1] (0 where
// k1 = k2 = 0, where atan2 is undefined). As vgraph.numerics.curvature computes them.
float curvature_measure(vec4 c) {
#if defined(CURVATURE_K1)
    return c.x;
#elif defined(CURVATURE_K2)
    return c.y;
#elif defined(CURVATURE_GAUSSIAN)
    return c.z;
#elif defined(CURVATURE_MEAN)
    return 0.5 * (c.x + c.y);
#elif defined(CURVATURE_CURVEDNESS)
    return sqrt(0.5 * (c.x * c.x + c.y * c.y));
#else  // CURVATURE_SHAPE_INDEX
    float sum = c.x + c.y;
    float difference = c.x - c.y;  // >= 0: k1 >= k2
    return sum == 0.0 && difference == 0.0 ? 0.0 : 0.63661977236758134 * atan(sum, difference);
#endif
}
