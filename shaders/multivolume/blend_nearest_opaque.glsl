// BLEND_NEAREST_OPAQUE: the first sample along the ray where some channel's TF opacity (as the TF
// gives it, not corrected for the step, so the hit does not move with the sampling rate) reaches
// opacity_threshold; the pixel is that channel's TF colour, opaque. Where several channels reach
// it at that sample, the most opaque wins (equal opacities: the lower slot). With
// SHADING_BLINN_PHONG the colour is shaded with that channel's gradient. Depth: the hit.
#ifdef BLEND_NEAREST_OPAQUE
uniform float opacity_threshold;

// The most opaque channel so far at one sample that reaches the threshold (color.a 0: none).
struct Hit {
    vec4 color;
    int channel;
    vec3 point;  // in the channel's texture space
};

void test_channel(int k, vec3 t, inout Hit hit) {
    vec3 tk;
    if (!channel_point(k, t, tk)) {
        return;
    }
    vec4 color = channel_classify(k, channel_value(k, tk));
    color.a *= sample_weight(t);  // 0: masked or cut away (raycasting/sample_weight.glsl)
    if (color.a >= opacity_threshold && color.a > hit.color.a) {
        hit = Hit(color, k, tk);
    }
}

Result march(Ray ray) {
    Result result = empty_result();
    for (int i = 0; i < ray.samples; ++i) {
        vec3 t = sample_point(ray, float(i));
        result.taken++;
        Hit hit = Hit(vec4(0.0), 0, t);
#define TEST_CHANNEL(k) test_channel(k, t, hit)
        FOR_EACH_CHANNEL(TEST_CHANNEL);
        if (hit.color.a > 0.0) {
#ifdef SHADING_BLINN_PHONG
            hit.color.rgb = shade(hit.color.rgb, channel_gradient(hit.channel, hit.point), -ray.direction);
#endif
            result.color = vec4(hit.color.rgb, 1.0);
            result.depth_sample = float(i);
            return result;
        }
    }
    return result;
}
#endif
