// Opacity arithmetic that keeps small opacities in float32 (issue 30). The plain forms
// 1 - exp2(x * log2(1 - a)) and 1 - exp(-d) round 1 - a and exp(-d) to float32's step below 1
// (6e-8) and lean on exp2/log2 near 0 and 1: measured on llvmpipe, a median relative error of
// 2 % for opacities 1e-6..1e-5, 14 % for 1e-7..1e-6 and all of it below 1e-8, a bias that adds up
// over the many samples of a faint medium. Opacities below SMALL_OPACITY and optical depths below
// SMALL_DEPTH go through the series of log1p and expm1 instead (relative error at most 5.7e-7 and
// 6.7e-7 measured, 1e-6 asserted: tests/test_reference_extremes.py); larger ones keep the plain
// forms, bit for bit.
const float SMALL_OPACITY = 1.0 / 64.0;  // the plain form's error here: 2e-5 (rate 4), 4e-4 (rate 100)
const float SMALL_DEPTH = 0.125;          // 5e-7 here; the series' truncation is 7e-10

// 1 - exp(-depth) for an optical depth >= 0 (-expm1(-depth)).
float opacity_of_depth(float depth) {
    if (depth >= SMALL_DEPTH) {
        return 1.0 - exp(-depth);
    }
    // sum of (-1)^(k+1) d^k / k!, k = 1..6, nested
    return depth * (1.0 - depth / 2.0 * (1.0 - depth / 3.0 * (1.0 - depth / 4.0
                   * (1.0 - depth / 5.0 * (1.0 - depth / 6.0)))));
}

// -ln(1 - alpha) >= 0, the optical depth of an opacity, for 0 <= alpha < 1: -log1p(-alpha).
float depth_of_opacity(float alpha) {
    if (alpha >= SMALL_OPACITY) {
        return -log(1.0 - alpha);
    }
    // alpha + alpha^2 / 2 + ... + alpha^5 / 5, nested (truncation below 2e-10)
    return alpha * (1.0 + alpha * (1.0 / 2.0 + alpha * (1.0 / 3.0 + alpha * (1.0 / 4.0 + alpha / 5.0))));
}

// 1 - (1 - alpha)^exponent for 0 <= alpha < 1 and exponent >= 0 (an opacity per one length seen
// over exponent lengths), for the ray casters' opacity correction, where the exponent is
// 1 / sampling rate: at and above SMALL_OPACITY the plain form, bit for bit as before;
// -expm1(exponent * log1p(-alpha)) below.
float corrected_alpha(float alpha, float exponent) {
    if (alpha >= SMALL_OPACITY) {
        return 1.0 - exp2(exponent * log2(1.0 - alpha));
    }
    return opacity_of_depth(exponent * depth_of_opacity(alpha));
}

// 1 - (1 - alpha)^lengths for any number of lengths >= 0, however small (a thin tetrahedron:
// there the plain form's exp2 near 0 loses opacities of any size, 0.5 included).
float opacity_over(float alpha, float lengths) {
    return opacity_of_depth(lengths * depth_of_opacity(alpha));
}
