// COMPOSITING_MIP in one brick: the maximum of the normalised intensity (clamped to [0, 1]) over the
// samples the brick owns and the first sample holding it. The result goes out as (maximum, sample,
// 0, 1) with gl_FragDepth = 1 - maximum under a LESS depth test, so across bricks (drawn front to
// back) the largest maximum wins and a tie keeps the front brick: the RayCaster's first maximum.
// Classification happens once, in resolve.frag.glsl. A brick with nothing above 0 writes nothing.
// Each intensity is weighed by the sample's mask and cut-away weight (at most 1, so the block
// ranges still bound it), as the RayCaster's.
//
// With SKIP_EMPTY_BLOCKS, as the RayCaster's MIP (raycasting/compositing_mip.glsl): the stretches
// of the span (its samples in one block) are taken in three passes: the block ranges alone for
// the stretch with the largest maximum, that stretch's samples, then front to back only the
// stretches that can still change the maximum or its first sample (before the depth sample a
// maximum within float32 rounding of `best`, after it one above `best`). Each brick starts from
// nothing, so front-to-back skipping alone, against a maximum that restarts at 0 in every brick,
// skipped even less than in the RayCaster.
#ifdef COMPOSITING_MIP
// Sample i's intensity clamped to [0, 1], or -1 where another brick owns it (never a maximum, never
// a tie: the maximum starts at 0).
float owned_value(Ray ray, int i) {
    vec3 t = sample_point(ray, float(i));
    return owns(t) ? min(intensity(t) * sample_weight(t), 1.0) : -1.0;  // 0: masked (sample_weight.glsl)
}

#ifdef SKIP_EMPTY_BLOCKS
// The stretch that starts at sample i: its end (the first sample past it) and its block's range.
int stretch_end(Ray ray, int i, out vec2 range) {
    ivec3 k = block_of(sample_point(ray, float(i)));
    range = block_range(k);
    return last_in_block(ray, k, i) + 1;
}

void composite(Ray ray, Span span, inout vec4 sum, inout float depth_sample) {  // (starts at 0)
    float tie_slack = 1e-6 * (1.0 + 2.0 * abs(intensity_offset));  // compositing_mip.glsl says why
    int end = span.last + 1;
    // 1. The largest block maximum over the span and the first stretch with it.
    float top = -1e30;
    int top_start = span.first;
    int top_end = span.first;
    for (int i = span.first; i < end;) {
        vec2 range;
        int next = stretch_end(ray, i, range);
        if (range.y > top) {
            top = range.y;
            top_start = i;
            top_end = min(next, end);
        }
        i = next;
    }
    // 2. That stretch.
    float best = 0.0;
    int best_sample = -1;
    float ceiling = min(top, 1.0);
    for (int i = top_start; i < top_end && best < ceiling; ++i) {
        float value = owned_value(ray, i);
        if (value > best) {
            best = value;
            best_sample = i;
        }
    }
    // 3. The rest, front to back.
    int i = span.first;
    while (i < end && !(i > best_sample && best >= ceiling)) {
        int stretch_stop = i;
        float stretch_bound = 0.0;
        while (i < end && !(i > best_sample && best >= ceiling)) {
            vec2 range;
            int next = stretch_end(ray, i, range);
            if ((i < best_sample ? range.y + tie_slack >= best : range.y > best) && i != top_start) {
                stretch_stop = min(next, end);
                stretch_bound = min(range.y, 1.0);
                break;
            }
            i = next;
        }
        for (int j = i; j < stretch_stop; ++j) {
            if (j > best_sample && best >= stretch_bound) {
                break;
            }
            float value = owned_value(ray, j);
            if (value > best || (value == best && j < best_sample)) {
                best = value;
                best_sample = j;
            }
        }
        i = max(i, stretch_stop);
    }
    depth_sample = float(best_sample);
    sum = vec4(best, depth_sample, 0.0, 1.0);
}
#else
void composite(Ray ray, Span span, inout vec4 sum, inout float depth_sample) {  // (starts at 0)
    float best = 0.0;
    depth_sample = -1.0;
    for (int i = span.first; i <= span.last; ++i) {
        float value = owned_value(ray, i);
        if (value > best) {
            best = value;
            depth_sample = float(i);
        }
    }
    sum = vec4(best, depth_sample, 0.0, 1.0);
}
#endif
#endif
