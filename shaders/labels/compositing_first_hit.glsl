// COMPOSITING_FIRST_HIT: surface-like: the colour of the first sample whose label is shown, opaque
// (the label's opacity only decides whether it is shown), shaded where SHADING_BLINN_PHONG.
#ifdef COMPOSITING_FIRST_HIT
vec4 march(Ray ray) {
    for (int i = 0; i < ray.samples; ++i) {
        vec3 t = sample_point(ray, float(i));
        Label label = majority_label(t);
        if (label.code != BACKGROUND) {
            return vec4(label_shade(code_color(label.code).rgb, label, ray), 1.0);
        }
    }
    return vec4(0.0);
}
#endif
