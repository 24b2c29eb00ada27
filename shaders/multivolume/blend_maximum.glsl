// BLEND_MAXIMUM: a maximum intensity projection per channel (intensities clamped to [0, 1], over
// the samples inside the channel's box; a channel the ray never meets adds nothing), each maximum
// classified once by its channel's TF, (rgb_k, a_k); colours added, premultiplied:
// C = min(sum a_k rgb_k, 1), coverage A = 1 - prod(1 - a_k). With one channel this is the
// RayCaster's mip. Depth: the first sample holding the maximum of the channel with the largest
// a_k (equal: the lower slot; channel 0's when none has opacity, as the RayCaster's mip).
#ifdef BLEND_MAXIMUM
Result march(Ray ray) {
    Result result = empty_result();
    float best[CHANNELS];
    int best_sample[CHANNELS];
    bool met[CHANNELS];
    for (int k = 0; k < CHANNELS; ++k) {
        best[k] = 0.0;  // clamped intensities: 0 is neutral
        best_sample[k] = 0;
        met[k] = false;
    }
    for (int i = 0; i < ray.samples; ++i) {
        vec3 t = sample_point(ray, float(i));
        result.taken++;
        for (int k = 0; k < CHANNELS; ++k) {
            vec3 tk;
            if (!channel_point(k, t, tk)) continue;
            met[k] = true;
            float value = min(channel_value(k, tk), 1.0);
            if (value > best[k]) {
                best[k] = value;
                best_sample[k] = i;
            }
        }
    }
    vec3 sum = vec3(0.0);
    float transparency = 1.0;
    float strongest = -1.0;
    for (int k = 0; k < CHANNELS; ++k) {
        if (!met[k]) continue;
        vec4 color = channel_classify(k, best[k]);
        sum += color.a * color.rgb;
        transparency *= 1.0 - color.a;
        if (color.a > strongest) {
            strongest = color.a;
            result.depth_sample = float(best_sample[k]);
        }
    }
    result.color = vec4(min(sum, vec3(1.0)), 1.0 - transparency);
    return result;
}
#endif
