// COMPOSITING_FIRST_HIT: surface-like: the colour of the first sample whose label is shown, opaque
// (the label's opacity only decides whether it is shown), shaded where SHADING_BLINN_PHONG. The hit
// between sample i - 1 (background) and sample i is refined by HIT_REFINEMENT halvings to where
// the majority rule turns to a shown label: its colour and surface normal there (a sample one step
// inside would often lie where all 8 voxels agree, with no slope to shade by). A ray that starts
// inside a label (a face of the volume or a cut) shows the label unrefined. With SKIP_EMPTY_SPACE,
// blocks without shown labels are jumped over (samples before a skip are background). The depth
// output's sample is the refined hit.
#ifdef COMPOSITING_FIRST_HIT
const int HIT_REFINEMENT = 6;  // the hit within 1/64 of a step

Label refined_hit(Ray ray, float outside, float inside, Label label) {
    for (int k = 0; k < HIT_REFINEMENT; ++k) {
        float middle = 0.5 * (outside + inside);
        Label here = majority_label(sample_point(ray, middle));
        if (here.code != BACKGROUND) {
            inside = middle;
            label = here;
        } else {
            outside = middle;
        }
    }
    depth_sample = inside;  // the depth output's sample (label_raycaster.frag.glsl)
    return label;
}

vec4 march(Ray ray) {
    March cursor = start_march(ray);
    while (cursor.i < ray.samples) {
        if (!next_occupied_sample(cursor, ray)) break;  // march.glsl
        vec3 t = sample_point(ray, float(cursor.i));
        Label label = majority_label(t);
        // A masked or cut-away sample (weight below 1/2, raycasting/sample_weight.glsl) is no hit;
        // after one, the hit is the sample itself: the labels are cut there.
        if (label.code != BACKGROUND && sample_weight(t) >= 0.5) {
            depth_sample = float(cursor.i);
            if (cursor.i > 0 && sample_weight(sample_point(ray, float(cursor.i - 1))) >= 0.5) {
                label = refined_hit(ray, float(cursor.i - 1), float(cursor.i), label);
            }
            return vec4(label_shade(code_color(label.code).rgb, label, ray), 1.0);
        }
        ++cursor.i;
    }
    return vec4(0.0);
}
#endif
