// COMPOSITING_MIP: maximum intensity projection. m = max over the samples of the normalised
// intensity clamped to [0, 1], classified once: colour (a rgb, a) with (rgb, a) = TF(m), no opacity
// correction, no shading. Depth: the first sample holding the maximum (sample 0 if all are <= 0).
//
// With SKIP_EMPTY_SPACE a block's value bounds every sample in it (its maximum with a voxel of
// margin, empty_space.glsl). Skipping, front to back, the blocks not above the running maximum
// saves little where the maxima lie inside the volume: the maximum rises slowly along the ray
// (torus 256^3: 108 of 165 samples per pixel taken). So the ray's stretches (its samples in one
// block, in the order of the block walk of empty_space.glsl) are taken in three passes:
//   1. the blocks only, one texelFetch each: the largest bound on the ray, `top`, and the first
//      stretch with it;
//   2. that stretch's samples: a maximum `best` usually close to the ray's;
//   3. front to back, the stretches that can still change the result: before the depth sample
//      one whose bound reaches `best` (an equal sample there becomes the first one holding the
//      maximum), after it one whose bound exceeds `best`; inside a stretch, the rest of it is
//      dropped once `best` reaches its bound, and the ray ends once `best` reaches `top` after
//      the depth sample.
// Every sample left out is bounded by a value that cannot change the maximum or its first sample,
// so image and depth are exactly those of the plain march (tests/test_mip_skipping.py); the torus
// takes 40 samples per pixel. In pass 3 the walk is a loop of its own with no sampling inside,
// followed by the stretch's samples: on llvmpipe a walk with the sample loop nested in it cost as
// much as the sampling itself, and one flat loop (a sample per iteration, the walk inside) was
// 5-20 % slower than this (process CPU time, bonsai and torus).
#ifdef COMPOSITING_MIP
#ifdef SKIP_EMPTY_SPACE
Result march(Ray ray) {
    Result result = empty_result();
    BlockWalk walk = block_walk(ray);
    // Block maxima are computed in float64 and stored in float32; a sample is raw * scale + offset
    // in float32, which may differ from the exact value by a few roundings of max(1, |offset|).
    // Before the depth sample a block is therefore taken when its maximum comes within that of
    // `best`: a sample equal to `best` there decides the depth. Elsewhere a block is skipped when
    // its maximum is not above `best`, the rule of the front-to-back skipping before (a slack
    // there would sample every block whose maximum equals `best`: bonsai 24 -> 69 samples per
    // pixel, its plateaus reach their block maxima).
    float tie_slack = 1e-6 * (1.0 + 2.0 * abs(intensity_offset));
    // 1. The largest block maximum and the first stretch that has it.
    float top = -1e30;
    int top_start = 0;
    int top_end = 0;
    for (int i = 0; i < ray.samples;) {
        ivec3 block = block_of(walk, i);
        int next = min(next_sample_outside(walk, i, block, 1.0, ray.samples), ray.samples);
        float bound = block_value(block);
        if (bound > top) {
            top = bound;
            top_start = i;
            top_end = next;
        }
        i = next;
    }
    // 2. That stretch. Intensities count clamped to [0, 1]; 0 (at sample 0) is neutral.
    float best = 0.0;
    int best_sample = 0;
    float ceiling = min(top, 1.0);  // no sample can count above this
    for (int i = top_start; i < top_end && best < ceiling; ++i) {
        float value = min(intensity(sample_point(ray, float(i))), 1.0);
        result.taken++;
        if (value > best) {
            best = value;
            best_sample = i;
        }
    }
    // 3. The rest, front to back: the walk to the next stretch that can change the result, then
    // its samples (until best reaches its bound).
    int i = 0;
    while (i < ray.samples && !(i > best_sample && best >= ceiling)) {
        int stretch_end = i;
        float stretch_bound = 0.0;
        while (i < ray.samples && !(i > best_sample && best >= ceiling)) {
            ivec3 block = block_of(walk, i);
            int next = min(next_sample_outside(walk, i, block, 1.0, ray.samples), ray.samples);
            float bound = block_value(block);
            if ((i < best_sample ? bound + tie_slack >= best : bound > best) && i != top_start) {
                stretch_end = next;
                stretch_bound = min(bound, 1.0);
                break;
            }
            i = next;
        }
        for (int j = i; j < stretch_end; ++j) {
            if (j > best_sample && best >= stretch_bound) {
                break;
            }
            float value = min(intensity(sample_point(ray, float(j))), 1.0);
            result.taken++;
            if (value > best || (value == best && j < best_sample)) {
                best = value;
                best_sample = j;
            }
        }
        i = max(i, stretch_end);
    }
    vec4 color = classify(best);
    result.color = vec4(color.rgb * color.a, color.a);
    result.depth_sample = float(best_sample);
    return result;
}
#else
Result march(Ray ray) {
    Result result = empty_result();
    float best = 0.0;  // intensities are clamped to [0, 1], so 0 is neutral
    int best_sample = 0;
    March cursor = start_march(ray);
    while (cursor.i < ray.samples && best < 1.0) {  // nothing exceeds 1 after clamping
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
#endif
