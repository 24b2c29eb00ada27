// COMPOSITING_FIRST_HIT: first-hit points (as Voreen's FHP): the texture coordinates of the first
// sample whose TF opacity is > 0, as rgb with alpha 1 (the encoding of the entry/exit images), for
// later passes. Depth: that sample. With SKIP_EMPTY_SPACE, blocks of zero opacity are skipped.
#ifdef COMPOSITING_FIRST_HIT
Result march(Ray ray) {
    Result result = empty_result();
#ifdef SKIP_EMPTY_SPACE
    BlockWalk walk = block_walk(ray);
#endif
    int i = 0;
    while (i < ray.samples) {
#ifdef SKIP_EMPTY_SPACE
        if (skipped_empty_region(walk, i, ray.samples)) continue;
#endif
        vec3 t = sample_point(ray, float(i));
        result.taken++;
        if (classify(intensity(t)).a > 0.0) {
            result.color = vec4(t, 1.0);
            result.depth_sample = float(i);
            return result;
        }
        ++i;
    }
    return result;
}
#endif
