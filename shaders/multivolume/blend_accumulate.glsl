// BLEND_ACCUMULATE: at each sample the channels are mixed into one sample (Cai & Sakas 1999,
// accumulation-level intermixing): opacity 1 - prod(1 - a'_k), colour the a'-weighted mean of the
// channels' TF colours (a'_k: opacity-corrected), then composited front to back like the
// RayCaster's dvr: C += (1 - A) a rgb, A += (1 - A) a, stopping once A >= early_termination.
// The mix does not depend on the channels' order; one channel gives its own sample. With
// SHADING_BLINN_PHONG each channel's colour is shaded with its own gradient before the mix (only
// channels with opacity there). Depth: the first sample with opacity.
#ifdef BLEND_ACCUMULATE
uniform float early_termination;

vec4 mixed_sample(vec3 t, vec3 view) {
    float transparency = 1.0;
    float weight = 0.0;
    vec3 weighted = vec3(0.0);
    for (int k = 0; k < CHANNELS; ++k) {
        vec3 tk;
        if (!channel_point(k, t, tk)) continue;
        vec4 color = channel_classify(k, channel_value(k, tk));
        if (color.a > 0.0) {
            float alpha = channel_opacity(k, color.a);
#ifdef SHADING_BLINN_PHONG
            color.rgb = shade(color.rgb, channel_gradient(k, tk), view);
#endif
            transparency *= 1.0 - alpha;
            weight += alpha;
            weighted += alpha * color.rgb;
        }
    }
    return weight > 0.0 ? vec4(weighted / weight, 1.0 - transparency) : vec4(0.0);
}

Result march(Ray ray) {
    Result result = empty_result();
    vec4 sum = vec4(0.0);
    for (int i = 0; i < ray.samples; ++i) {
        vec4 color = mixed_sample(sample_point(ray, float(i)), -ray.direction);
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
