// COMPOSITING_DVR in one brick: the RayCaster's front-to-back sum (raycasting/compositing_dvr.glsl)
// over the samples the brick owns, without early termination (the sum of the bricks in front is
// not readable here). The pass blends the brick's premultiplied sum under what the bricks in front
// left: C += (1 - A) C_brick, A += (1 - A) A_brick, which is the same sum regrouped. Depth: the
// brick's first sample with a' > 0 (the blend keeps the frontmost).
#ifdef COMPOSITING_DVR
void composite(Ray ray, Span span, out vec4 sum, out float depth_sample) {
    sum = vec4(0.0);
    depth_sample = -1.0;
    for (int i = span.first; i <= span.last; ++i) {
        vec3 t = sample_point(ray, float(i));
        if (!owns(t)) {
            continue;
        }
        float raw = raw_sample(t);
        vec4 color = classify(raw * intensity_scale + intensity_offset);
        if (color.a > 0.0) {
            float alpha = corrected_opacity(color.a);
#ifdef SHADING_BLINN_PHONG
            color.rgb = shade(color.rgb, gradient(t, raw), -ray.direction);
#endif
            if (depth_sample < 0.0) {
                depth_sample = float(i);
            }
            float weight = (1.0 - sum.a) * alpha;
            sum += vec4(weight * color.rgb, weight);
        }
    }
}
#endif
