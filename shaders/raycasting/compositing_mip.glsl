// COMPOSITING_MIP: maximum intensity projection. m = max over the samples of the normalised
// intensity clamped to [0, 1], classified once: colour (a rgb, a) with (rgb, a) = TF(m), no opacity
// correction, no shading. Depth: the first sample holding the maximum (sample 0 if all are <= 0).
// With SKIP_EMPTY_SPACE, blocks whose maximum does not exceed the current one are skipped.
#ifdef COMPOSITING_MIP
Result march(Ray ray) {
    Result result = empty_result();
    float best = 0.0;  // intensities are clamped to [0, 1], so 0 is neutral
    int best_sample = 0;
    March cursor = start_march(ray);
    while (cursor.i < ray.samples && best < 1.0) {  // nothing exceeds 1 after clamping
#ifdef SKIP_EMPTY_SPACE
        // Not skip_empty_space(): here a block's value is its maximum (empty_space.glsl).
        ivec3 block = block_of(cursor.walk, cursor.i);
        if (block_value(block) <= best) {
            cursor.i = next_sample_outside(cursor.walk, cursor.i, block, 1.0, ray.samples);
            continue;
        }
#endif
        float value = intensity(sample_point(ray, float(cursor.i)));
        result.taken++;
        if (value > best) {
            best = value;
            best_sample = cursor.i;
        }
        ++cursor.i;
    }
    vec4 color = classify(min(best, 1.0));
    result.color = vec4(color.rgb * color.a, color.a);
    result.depth_sample = float(best_sample);
    return result;
}
#endif
