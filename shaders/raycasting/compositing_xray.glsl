// COMPOSITING_XRAY: x-ray / average intensity: m = the mean of the normalised intensity (clamped
// to [0, 1]) along the ray, classified once like MIP: colour (a rgb, a) with (rgb, a) = TF(m).
// The samples 0 .. samples - 1 weigh one step each and the exit point weighs what is left of the
// ray after the last sample (0 to 1 step): without it the mean would jump wherever the ray's
// length passes a whole number of steps (banding). Nothing is skipped. Depth: the entry point.
#ifdef COMPOSITING_XRAY
Result march(Ray ray) {
    Result result = empty_result();
    float sum = 0.0;
    for (int i = 0; i < ray.samples; ++i) {
        vec3 t = sample_point(ray, float(i));
        sum += clamp(intensity(t), 0.0, 1.0) * sample_weight(t);
    }
    float rest = clamp(ray.steps - float(ray.samples - 1), 0.0, 1.0);
    sum += rest * clamp(intensity(ray.end), 0.0, 1.0) * sample_weight(ray.end);
    vec4 color = classify(sum / (float(ray.samples) + rest));
    result.color = vec4(color.rgb * color.a, color.a);
    result.depth_sample = 0.0;
    result.taken = ray.samples + 1;
    return result;
}
#endif
