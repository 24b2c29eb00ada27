// COMPOSITING_DVR in one brick: the RayCaster's front-to-back sum (raycasting/compositing_dvr.glsl)
// over the samples the brick owns, continued from `sum` and `depth_sample`:
// - blended (the default): they start at 0 and the pass blends the brick's premultiplied sum under
//   what the bricks in front left, C += (1 - A) C_brick, A += (1 - A) A_brick: the same sum
//   regrouped, without early termination (a pass cannot read the target it blends into);
// - READ_ACCUMULATION: they start at what the bricks in front left (front_state.glsl), so the sum
//   is the RayCaster's, sample by sample, and EARLY_TERMINATION stops it where the RayCaster does
//   (once A >= early_termination).
// Depth: the first sample with a' > 0. A brick of a coarse level takes only the samples of its
// lattice, each for the level-0 samples up to the next (brick_span.glsl: owned_run, next_taken,
// stepped_opacity); at level 0 every candidate is tested and taken as before. A sample's opacity is
// weighed by its mask and cut-away weight (sample_weight) before anything else, as the RayCaster's.
#include "raycasting/gradient_classification.glsl"  // classify_sample(): gradient opacity
#ifdef COMPOSITING_DVR
uniform float early_termination;

void composite(Ray ray, Span span, inout vec4 sum, inout float depth_sample) {
#ifdef EARLY_TERMINATION
    if (sum.a >= early_termination) {
        return;  // the ray stopped in a brick in front
    }
#endif
    Span run = level_stride == 1 ? span : owned_run(ray, span);
    int next = run.first;
    for (int i = run.first; i <= run.last; i = next) {
        next = next_taken(i, run.last);
        vec3 t = sample_point(ray, float(i));
        if (!owns(t)) {
            continue;
        }
        SKIP_BLOCK_TO(ray, t, i, next, transparent(range))
        float raw = raw_sample(t);
        vec4 color = classify_sample(t, raw * intensity_scale + intensity_offset);  // gradient_classification.glsl
        color.a *= sample_weight(t);  // 0: masked or cut away (raycasting/sample_weight.glsl)
        if (color.a > 0.0) {
            float alpha = stepped_opacity(color.a, next - i);
#ifdef SHADING_BLINN_PHONG
            color.rgb = shade(color.rgb, gradient(t, raw), -ray.direction);
#endif
            if (depth_sample < 0.0) {
                depth_sample = float(i);
            }
            float weight = (1.0 - sum.a) * alpha;
            sum += vec4(weight * color.rgb, weight);
#ifdef EARLY_TERMINATION
            if (sum.a >= early_termination) {
                break;
            }
#endif
        }
    }
}
#endif
