// COMPOSITING_COMPOSITE: every shown label's colour at its opacity, front-to-back (Inacio 2009
// eq. 2.3-2.4): C += (1 - A) a' rgb, A += (1 - A) a', a' = 1 - (1 - opacity)^(1 / sampling_rate)
// (opacity is per sample at rate 1), shaded where SHADING_BLINN_PHONG (inside a label the weight
// sum has no slope and the colour stays unshaded). Background samples add nothing. The ray stops
// once A >= early_termination.
#ifdef COMPOSITING_COMPOSITE
uniform float early_termination;
uniform float opacity_exponent;  // 1 / sampling_rate

vec4 march(Ray ray) {
    vec4 sum = vec4(0.0);
    for (int i = 0; i < ray.samples; ++i) {
        vec3 t = sample_point(ray, float(i));
        Label label = majority_label(t);
        if (label.code == BACKGROUND) {
            continue;
        }
        vec4 color = code_color(label.code);
        float alpha = 1.0 - pow(1.0 - color.a, opacity_exponent);
        vec3 rgb = label_shade(color.rgb, label, ray);
        float weight = (1.0 - sum.a) * alpha;
        sum += vec4(weight * rgb, weight);
        if (sum.a >= early_termination) {
            break;
        }
    }
    return sum;
}
#endif
