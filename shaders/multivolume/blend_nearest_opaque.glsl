// BLEND_NEAREST_OPAQUE: the first sample along the ray where some channel's TF opacity (as the TF
// gives it, not corrected for the step, so the hit does not move with the sampling rate) reaches
// opacity_threshold; the pixel is that channel's TF colour, opaque. Where several channels reach
// it at that sample, the most opaque wins (equal opacities: the lower slot). With
// SHADING_BLINN_PHONG the colour is shaded with that channel's gradient. Depth: the hit.
#ifdef BLEND_NEAREST_OPAQUE
uniform float opacity_threshold;

Result march(Ray ray) {
    Result result = empty_result();
    for (int i = 0; i < ray.samples; ++i) {
        vec3 t = sample_point(ray, float(i));
        result.taken++;
        vec4 hit = vec4(0.0);
        int hit_channel = 0;
        vec3 hit_point = t;
        for (int k = 0; k < CHANNELS; ++k) {
            vec3 tk;
            if (!channel_point(k, t, tk)) continue;
            vec4 color = channel_classify(k, channel_value(k, tk));
            if (color.a >= opacity_threshold && color.a > hit.a) {
                hit = color;
                hit_channel = k;
                hit_point = tk;
            }
        }
        if (hit.a > 0.0) {
#ifdef SHADING_BLINN_PHONG
            hit.rgb = shade(hit.rgb, channel_gradient(hit_channel, hit_point), -ray.direction);
#endif
            result.color = vec4(hit.rgb, 1.0);
            result.depth_sample = float(i);
            return result;
        }
    }
    return result;
}
#endif
