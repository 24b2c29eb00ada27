// Classification by value and gradient magnitude (vgraph.gl.raycasting.gradient_classification;
// the CPU reference's model: vgraph.numerics.reference_classification). Include it after
// transfer_function.glsl. classify_sample(t, value) is the RGBA of the sample at texture point t
// with normalised intensity `value`:
// - TRANSFER_FUNCTION_2D: the 2D TF's table at (value, gradient fraction), replacing classify();
// - GRADIENT_OPACITY: alpha times the curve at the gradient fraction;
// - neither: classify(value) itself (a macro: the plain code, compiled exactly as before).
// The gradient fraction is |gradient| / the volume's largest voxel gradient magnitude, the gradient
// read from the precomputed gradient volume (gradient_volume.py's encoding, as gradients.glsl), or
// with CLASSIFICATION_CENTRAL (the bricks, which have no gradient volume) computed at the sample
// as central differences one level-0 voxel apart of the interpolated intensity(): the same number,
// since trilinear interpolation commutes with a shift by whole voxels (only the gradient volume's
// 16-bit rounding differs).
#if defined(GRADIENT_OPACITY) || defined(TRANSFER_FUNCTION_2D)
uniform float inverse_largest_gradient;        // 1 / max |g| over the voxels (0 for a constant volume)
#ifdef CLASSIFICATION_CENTRAL
uniform vec3 classification_voxel_step;        // one level-0 voxel in texture space: 1 / dims
uniform vec3 classification_inverse_span;      // 1 / (2 spacing): differences -> per world unit

float gradient_fraction(vec3 t) {
    vec3 dx = vec3(classification_voxel_step.x, 0.0, 0.0);
    vec3 dy = vec3(0.0, classification_voxel_step.y, 0.0);
    vec3 dz = vec3(0.0, 0.0, classification_voxel_step.z);
    vec3 g = vec3(intensity(t + dx) - intensity(t - dx), intensity(t + dy) - intensity(t - dy),
                  intensity(t + dz) - intensity(t - dz)) * classification_inverse_span;
    return length(g) * inverse_largest_gradient;
}
#else
uniform sampler3D classification_gradients;   // RGBA16: rgb = (32767 + g / scale * 32767) / 65535
uniform vec3 classification_gradient_scale;   // per-axis max |g|

float gradient_fraction(vec3 t) {
    vec3 texel = textureLod(classification_gradients, t, 0.0).rgb;  // explicit LOD: inside loops
    vec3 g = (texel * (65535.0 / 32767.0) - 1.0) * classification_gradient_scale;
    return length(g) * inverse_largest_gradient;
}
#endif

// Entry i of an n-entry table sits at (i + 0.5) / n and stands for i / (n - 1); clamp-to-edge
// holds the end entries beyond [0, 1].
vec2 table_coordinates(vec2 at, vec2 n) {
    return at * ((n - 1.0) / n) + 0.5 / n;
}

#ifdef TRANSFER_FUNCTION_2D
uniform sampler2D transfer_function_2d;  // premultiplied RGBA, [gradient, value] rows: x = value, y = gradient fraction
#endif
#ifdef GRADIENT_OPACITY
uniform sampler2D gradient_opacity;  // n x 1, the factor in every channel
#endif

vec4 classify_sample(vec3 t, float value) {
    float fraction = gradient_fraction(t);
#ifdef TRANSFER_FUNCTION_2D
    vec2 n = vec2(textureSize(transfer_function_2d, 0));
    vec4 color = textureLod(transfer_function_2d, table_coordinates(vec2(value, fraction), n), 0.0);
    color.rgb = color.a > 0.0 ? color.rgb / color.a : vec3(0.0);  // the table is premultiplied
#else
    vec4 color = classify(value);
#endif
#ifdef GRADIENT_OPACITY
    float size = float(textureSize(gradient_opacity, 0).x);
    color.a *= textureLod(gradient_opacity, vec2(table_coordinates(vec2(fraction), vec2(size)).x, 0.5), 0.0).r;
#endif
    return color;
}
#else
#define classify_sample(t, value) classify(value)
#endif
