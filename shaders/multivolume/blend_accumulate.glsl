// BLEND_ACCUMULATE: at each sample the channels are mixed into one sample (Cai & Sakas 1999,
// accumulation-level intermixing): opacity 1 - prod(1 - a'_k), colour the a'-weighted mean of the
// channels' TF colours (a'_k: opacity-corrected), then composited front to back like the
// RayCaster's dvr: C += (1 - A) a rgb, A += (1 - A) a, stopping once A >= early_termination.
// The mix does not depend on the channels' order; one channel gives its own sample. With
// SHADING_BLINN_PHONG each channel's colour is shaded with its own gradient before the mix (only
// channels with opacity there). Depth: the first sample with opacity.
#ifdef BLEND_ACCUMULATE
uniform float early_termination;

// The running mix of one sample's channels.
struct Mix {
    float transparency;  // prod(1 - a'_k)
    float weight;        // sum a'_k
    vec3 weighted;       // sum a'_k rgb_k
};

void mix_channel(int k, vec3 t, vec3 view, bool shaded, inout Mix mixed) {
    vec3 tk;
    if (!channel_point(k, t, tk)) {
        return;
    }
    vec4 color = channel_classify(k, channel_value(k, tk));
    color.a *= sample_weight(t);  // 0: masked or cut away (raycasting/sample_weight.glsl)
    if (color.a > 0.0) {
        float alpha = channel_opacity(k, color.a);
#ifdef SHADING_BLINN_PHONG
        if (shaded) {
            color.rgb = shade(color.rgb, channel_gradient(k, tk), view);
        }
#endif
        mixed.transparency *= 1.0 - alpha;
        mixed.weight += alpha;
        mixed.weighted += alpha * color.rgb;
    }
}

// The mixed sample at t; `shaded` is a literal at each call, so the compiler drops the branch.
vec4 mixed_sample(vec3 t, vec3 view, bool shaded) {
    Mix mixed = Mix(1.0, 0.0, vec3(0.0));
#define MIX_CHANNEL(k) mix_channel(k, t, view, shaded, mixed)
    FOR_EACH_CHANNEL(MIX_CHANNEL);
    return mixed.weight > 0.0 ? vec4(mixed.weighted / mixed.weight, 1.0 - mixed.transparency) : vec4(0.0);
}

Result march(Ray ray) {
    Result result = empty_result();
    vec4 sum = vec4(0.0);
    int i = 0;
#ifdef SHADING_BLINN_PHONG
    // First the samples up to the first visible one, without the shading code (as the RayCaster's
    // dvr does: SIMD GL runs a branch for a group of pixels when one of them takes it, so rays
    // still in empty space would wait for their neighbours' shading. llvmpipe, one shaded channel:
    // 2.4x the RayCaster's time without this loop, 1.1-1.3x with it).
    for (; i < ray.samples; ++i) {
        if (mixed_sample(sample_point(ray, float(i)), -ray.direction, false).a > 0.0) {
            break;
        }
        result.taken++;
    }
#endif
    for (; i < ray.samples; ++i) {
        vec4 color = mixed_sample(sample_point(ray, float(i)), -ray.direction, true);
        result.taken++;
        if (color.a > 0.0) {
            if (result.depth_sample < 0.0) {
                result.depth_sample = float(i);
            }
            float weight = (1.0 - sum.a) * color.a;
            sum += vec4(weight * color.rgb, weight);
            if (sum.a >= early_termination) {
                break;
            }
        }
    }
    result.color = sum;
    return result;
}
#endif
