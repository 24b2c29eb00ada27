// COMPOSITING_COMPOSITE: every shown label's colour at its opacity, front-to-back (Inacio 2009
// eq. 2.3-2.4): C += (1 - A) a' rgb, A += (1 - A) a', a' = 1 - (1 - opacity)^(1 / sampling_rate)
// (opacity is per sample at rate 1; below 1/64 in the stable form of raycasting/opacity.glsl),
// shaded where SHADING_BLINN_PHONG (inside a label the weight sums have no slope and the colour
// stays unshaded). Background samples add nothing. The ray stops once A >= early_termination.
// With SKIP_EMPTY_SPACE, blocks without shown labels are jumped over.
#ifdef COMPOSITING_COMPOSITE
#include "raycasting/opacity.glsl"
uniform float early_termination;
uniform float opacity_exponent;  // 1 / sampling_rate

vec4 march(Ray ray) {
    vec4 sum = vec4(0.0);
    March cursor = start_march(ray);
    while (cursor.i < ray.samples) {
        if (!next_occupied_sample(cursor, ray)) break;  // march.glsl
        vec3 t = sample_point(ray, float(cursor.i));
        Label label = majority_label(t);
        float kept = sample_weight(t);  // 0: masked or cut away (raycasting/sample_weight.glsl)
        if (label.code != BACKGROUND && kept > 0.0) {
            if (depth_sample < 0.0) {
                depth_sample = float(cursor.i);  // the depth output's sample: the first shown label
            }
            vec4 color = code_color(label.code);
            color.a *= kept;
            float alpha = color.a >= SMALL_OPACITY ? 1.0 - pow(1.0 - color.a, opacity_exponent)
                          : opacity_of_depth(opacity_exponent * depth_of_opacity(color.a));
            float weight = (1.0 - sum.a) * alpha;
            sum += vec4(weight * label_shade(color.rgb, label, ray), weight);
            if (sum.a >= early_termination) {
                break;
            }
        }
        ++cursor.i;
    }
    return sum;
}
#endif
