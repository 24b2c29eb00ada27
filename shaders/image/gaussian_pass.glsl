// One axis of a separable Gaussian (scipy.ndimage.gaussian_filter1d): weights
// exp(-x^2 / (2 sigma^2)) for x in -radius..radius, normalised to sum 1. Needs edge_texel.glsl.
uniform float sigma;  // pixels; > 0
uniform int radius;   // int(truncate * sigma + 0.5), as scipy
uniform ivec2 axis_step;  // (1, 0) along rows, (0, 1) along columns

vec4 gaussian_along(sampler2D image, ivec2 pixel) {
    vec4 sum = vec4(0.0);
    float total = 0.0;
    for (int x = -radius; x <= radius; ++x) {
        float weight = exp(-0.5 * float(x * x) / (sigma * sigma));
        sum += weight * edge_texel(image, pixel + x * axis_step);
        total += weight;
    }
    return sum / total;
}
