// COMPOSITING_FIRST_HIT: surface-like: the colour of the first sample whose label is shown, opaque
// (the label's opacity only decides whether it is shown), shaded where SHADING_BLINN_PHONG. With
// SKIP_EMPTY_SPACE, blocks without shown labels are jumped over.
#ifdef COMPOSITING_FIRST_HIT
vec4 march(Ray ray) {
    March cursor = start_march(ray);
    while (cursor.i < ray.samples) {
        if (skip_empty_space(cursor, ray)) continue;  // march.glsl
        Label label = majority_label(sample_point(ray, float(cursor.i)));
        if (label.code != BACKGROUND) {
            return vec4(label_shade(code_color(label.code).rgb, label, ray), 1.0);
        }
        ++cursor.i;
    }
    return vec4(0.0);
}
#endif
