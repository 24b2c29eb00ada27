// BLEND_MAXIMUM: a maximum intensity projection per channel (intensities clamped to [0, 1], over
// the samples inside the channel's box; a channel the ray never meets adds nothing), each maximum
// classified once by its channel's TF, (rgb_k, a_k); colours added, premultiplied:
// C = min(sum a_k rgb_k, 1), coverage A = 1 - prod(1 - a_k). With one channel this is the
// RayCaster's mip. Depth: the first sample holding the maximum of the channel with the largest
// a_k (equal: the lower slot; channel 0's when none has opacity, as the RayCaster's mip).
#ifdef BLEND_MAXIMUM
struct Maxima {
    float best[CHANNELS];       // clamped intensities: 0 is neutral
    int best_sample[CHANNELS];
    bool met[CHANNELS];         // whether a sample lay in the channel's box
};

void take_channel(int k, vec3 t, int i, inout Maxima m) {
    vec3 tk;
    if (!channel_point(k, t, tk)) {
        return;
    }
    m.met[k] = true;
    float value = min(channel_value(k, tk), 1.0) * sample_weight(t);  // 0: masked (sample_weight.glsl)
    if (value > m.best[k]) {
        m.best[k] = value;
        m.best_sample[k] = i;
    }
}

// Channel k's maximum classified and added to the premultiplied sum.
void add_channel(int k, Maxima m, inout vec3 sum, inout float transparency, inout float strongest,
                 inout Result result) {
    if (!m.met[k]) {
        return;
    }
    vec4 color = channel_classify(k, m.best[k]);
    sum += color.a * color.rgb;
    transparency *= 1.0 - color.a;
    if (color.a > strongest) {
        strongest = color.a;
        result.depth_sample = float(m.best_sample[k]);
    }
}

Result march(Ray ray) {
    Result result = empty_result();
    Maxima m;
#define RESET_CHANNEL(k) m.best[k] = 0.0; m.best_sample[k] = 0; m.met[k] = false
    FOR_EACH_CHANNEL(RESET_CHANNEL);
    for (int i = 0; i < ray.samples; ++i) {
        vec3 t = sample_point(ray, float(i));
        result.taken++;
#define TAKE_CHANNEL(k) take_channel(k, t, i, m)
        FOR_EACH_CHANNEL(TAKE_CHANNEL);
    }
    vec3 sum = vec3(0.0);
    float transparency = 1.0;
    float strongest = -1.0;
#define ADD_CHANNEL(k) add_channel(k, m, sum, transparency, strongest, result)
    FOR_EACH_CHANNEL(ADD_CHANNEL);
    result.color = vec4(min(sum, vec3(1.0)), 1.0 - transparency);
    return result;
}
#endif
