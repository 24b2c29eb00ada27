// COMPOSITING_MIP: maximum intensity projection. m = max over the samples of the normalised
// intensity clamped to [0, 1], classified once: colour (a rgb, a) with (rgb, a) = TF(m), no opacity
// correction, no shading. Depth: the first sample holding the maximum (sample 0 if all are <= 0).
//
// With SKIP_EMPTY_SPACE a block's value bounds every sample in it (its maximum with a voxel of
// margin, empty_space.glsl). Skipping, front to back, the blocks not above the running maximum
// saves little where the maxima lie inside the volume: the maximum rises slowly along the ray
// (torus 256^3: 108 of 165 samples per pixel taken). So the ray's stretches (its samples in one
// block, in the order of the walk over the blocks below) are taken in three passes:
//   1. the blocks only, one texelFetch each: the largest bound on the ray, `top`, and the first
//      stretch with it, and the stretch with the next largest bound (`second`);
//   2. those two stretches' samples: a maximum `best` usually close to the ray's (the second
//      stretch took the bonsai from 23.8 to 21.2 samples per pixel and 7-12 % less CPU per frame:
//      a block next to the top one often holds the same voxel in its margin);
//   3. front to back, the stretches that can still change the result: before the depth sample
//      one whose bound reaches `best` (an equal sample there becomes the first one holding the
//      maximum), after it one whose bound exceeds `best`; inside a stretch, the rest of it is
//      dropped once `best` reaches its bound, and the ray ends once `best` reaches `top` after
//      the depth sample. The two stretches of pass 2 are not taken again.
// Every sample left out is bounded by a value that cannot change the maximum or its first sample,
// so image and depth are exactly those of the plain march (tests/test_mip_skipping.py); the torus
// takes 40 samples per pixel. In pass 3 the walk is a loop of its own with no sampling inside,
// followed by the stretch's samples: on llvmpipe a walk with the sample loop nested in it cost as
// much as the sampling itself, and one flat loop (a sample per iteration, the walk inside) was
// 5-20 % slower than this (process CPU time, bonsai and torus). The walk steps from block to block
// (a DDA) rather than recomputing the block of a sample index (empty_space.glsl's
// next_sample_outside): up to 20 % less, never more.
//
// The single-pass bricked ray caster (PAGED_MIP_WALK, bricks/paged_sampling.glsl) takes the same
// three passes over a grid of block maxima it builds over the frame's bricks (vgraph.bricks.walk_grids);
// a stretch's samples read their cells' slots through its runs (paged_ready), so a ray looks the
// page table up only where it samples: front to back it looked up every block on its way.
// A frame with missing bricks (PAGED_MIP_ASKS, under PAGED_REQUESTS) walks too, and asks for the
// missing cells its rays reach exactly as the plain march does (bricks/ray_requests.glsl: at a run's
// start, once per ray, a cell behind the first sample of 1 never): the grid's .g flags the blocks
// of missing cells, which pass 1 leaves out of the two stretches of pass 2 (so no ray asks out of
// order or past that sample) but not out of `ceiling`, and pass 3 goes on to that sample or the
// ray's end, visiting the flagged blocks' runs (take_and_ask) besides sampling what can change
// the result.
#ifdef COMPOSITING_MIP
#if defined(SKIP_EMPTY_SPACE) || defined(PAGED_MIP_WALK)
// The walk over the blocks (a 3D DDA, Amanatides & Woo 1987, in block coordinates of
// empty_space.glsl): each step gives the block the ray is in and the end of its stretch, the first
// sample index past the ray's exit from the block (samples at or past the exit belong to the next
// one; a stretch may be empty where the ray clips a block's corner between two samples). Blocks
// outside the grid (a ray starting on the box's face) stand for the edge block, which covers them.
struct Cells {
    ivec3 cell;
    ivec3 dir;
    vec3 t_max;    // sample index (fractional) where the ray leaves the cell along each axis
    vec3 t_delta;
};

Cells first_cell(BlockWalk walk) {
    Cells c;
    c.cell = clamp(ivec3(floor(walk.start)), ivec3(0), block_count - 1);
    c.dir = ivec3(sign(walk.step));
    vec3 face = vec3(c.cell) + step(vec3(0.0), walk.step);
    c.t_delta = abs(walk.steps_per_unit);
    c.t_max = mix(vec3(1e30), (face - walk.start) * walk.steps_per_unit, notEqual(walk.step, vec3(0.0)));
    return c;
}

int leave_cell(inout Cells c, int samples, out ivec3 block) {
    block = clamp(c.cell, ivec3(0), block_count - 1);
    float t = min(min(c.t_max.x, c.t_max.y), c.t_max.z);
    bvec3 axis = lessThanEqual(c.t_max, vec3(t));
    c.cell += ivec3(axis) * c.dir;
    c.t_max += vec3(axis) * c.t_delta;
    return min(int(floor(clamp(t, -1.0, float(samples)))) + 1, samples);
}

// Samples [start, end) of a stretch front to back, into the ray's maximum `best` and the first sample
// holding it, `best_sample`. `bound` (at most 1) bounds every sample of the stretch: past the depth
// sample the rest of the stretch is dropped once `best` reaches it (false: dropped); before it a
// sample equal to `best` still moves the depth sample forward.
bool take_samples(Ray ray, int start, int end, float bound, inout float best, inout int best_sample,
                  inout Result result) {
    for (int j = start; j < end; ++j) {
        if (j > best_sample && best >= bound) {
            return false;
        }
        vec3 t = sample_point(ray, float(j));
        float value = min(intensity(t) * sample_weight(t), 1.0);  // 0: masked (sample_weight.glsl)
        result.taken++;
        if (value > best || (value == best && j < best_sample)) {
            best = value;
            best_sample = j;
        }
    }
    return true;
}

// A stretch's samples [start, end), take_samples(); the three passes take every stretch through here.
// The single pass (PAGED_MIP_WALK) takes them run by run (paged_ready: the page table looked up
// where a run starts, cells and blocks that add nothing jumped): a check at every sample instead
// cost the bonsai 75 against 51 ms of CPU a frame (llvmpipe runs a loop's head for the 8 pixels of
// a SIMD group at every sample).
void take_stretch(Ray ray, int start, int end, float bound, inout float best, inout int best_sample,
                  inout Result result) {
#ifdef PAGED_MIP_WALK
    int j = start;
    while (paged_ready(j, end, ray)) {
        int stop = min(end, paged_run_end);
        if (!take_samples(ray, j, stop, bound, best, best_sample, result)) {
            return;
        }
        j = stop;
    }
#else
    take_samples(ray, start, end, bound, best, best_sample, result);
#endif
}

#ifdef PAGED_MIP_ASKS
// Whether the block holds a cell the atlas misses (the grid's .g: vgraph.bricks.walk_grids.asking_grid).
bool block_asks(ivec3 block) {
    return texelFetch(blocks, block, 0).g > 0.5;
}

// A stretch of a flagged block, in one pass forward over its runs (paged_ready; a run's start in a
// missing cell asks for it, paged_run): its samples taken while `sample` (while they can change the
// result: take_samples), then its runs only looked up, up to the sample holding a maximum of 1,
// where the plain march stops. (Taking, then walking the runs again from `start`, asked twice for
// a cell out of order, which bricks/ray_requests.glsl counts twice: it keeps only the last one.)
void take_and_ask(Ray ray, int start, int end, bool sample, float bound, inout float best, inout int best_sample,
                  inout Result result) {
    int j = start;
    while (paged_ready(j, best >= 1.0 ? min(end, best_sample + 1) : end, ray)) {
        int stop = min(end, paged_run_end);
        if (sample) {
            sample = take_samples(ray, j, stop, bound, best, best_sample, result);
        }
        j = stop;
    }
}
#endif

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
    float second = -1e30;
    int second_start = -1;
    int second_end = -1;
#ifdef PAGED_MIP_ASKS
    float top_all = -1e30;  // the largest bound, the missing cells' blocks too
    top_start = -1;
    top_end = -1;
#endif
    Cells cells = first_cell(walk);
    for (int i = 0; i < ray.samples;) {
        ivec3 block;
        int next = leave_cell(cells, ray.samples, block);
        if (next <= i) {
            continue;  // no sample in this block
        }
        float bound = block_value(block);
#ifdef PAGED_MIP_ASKS
        top_all = max(top_all, bound);
        if (block_asks(block)) {
            i = next;
            continue;
        }
#endif
        if (bound > top) {
            second = top;
            second_start = top_start;
            second_end = top_end;
            top = bound;
            top_start = i;
            top_end = next;
        } else if (bound > second) {
            second = bound;
            second_start = i;
            second_end = next;
        }
        i = next;
    }
    // 2. That stretch, then the second one. Intensities count clamped to [0, 1]; 0 (at sample 0) is
    // neutral, so a top stretch bounded by 0 or less is not sampled.
    float best = 0.0;
    int best_sample = 0;
#ifdef PAGED_MIP_ASKS
    float ceiling = min(top_all, 1.0);  // no sample can count above this
    float end_at = 1.0;                 // the plain march asks up to the first sample of 1
    if (min(top, 1.0) > 0.0) {
        take_stretch(ray, top_start, top_end, min(top, 1.0), best, best_sample, result);
    }
#else
    float ceiling = min(top, 1.0);  // no sample can count above this
    float end_at = ceiling;
    if (ceiling > 0.0) {
        take_stretch(ray, top_start, top_end, ceiling, best, best_sample, result);
    }
#endif
    take_stretch(ray, second_start, second_end, min(second, 1.0), best, best_sample, result);
    // 3. The rest, front to back: the walk to the next stretch that can change the result, then
    // its samples (until best reaches its bound). (PAGED_MIP_ASKS: past `ceiling` no stretch can,
    // only the flagged blocks' runs are visited.)
    int i = 0;
    cells = first_cell(walk);  // the same walk again
    while (i < ray.samples && !(i > best_sample && best >= end_at)) {
        int stretch_end = i;
        float stretch_bound = 0.0;
#ifdef PAGED_MIP_ASKS
        bool asks = false;
        bool changes = false;
#endif
        while (i < ray.samples && !(i > best_sample && best >= end_at)) {
            ivec3 block;
            int next = leave_cell(cells, ray.samples, block);
            if (next <= i) {
                continue;
            }
            float bound = block_value(block);
#ifdef PAGED_MIP_ASKS
            changes = (i < best_sample ? bound + tie_slack >= best : bound > best) && i != top_start && i != second_start;
            asks = block_asks(block);
            if (changes || asks) {
                stretch_end = next;
                stretch_bound = changes ? min(bound, 1.0) : 0.0;
                break;
            }
#else
            if ((i < best_sample ? bound + tie_slack >= best : bound > best) && i != top_start && i != second_start) {
                stretch_end = next;
                stretch_bound = min(bound, 1.0);
                break;
            }
#endif
            i = next;
        }
#ifdef PAGED_MIP_ASKS
        if (asks) {
            take_and_ask(ray, i, stretch_end, changes, stretch_bound, best, best_sample, result);
        } else {
            take_stretch(ray, i, stretch_end, stretch_bound, best, best_sample, result);
        }
#else
        take_stretch(ray, i, stretch_end, stretch_bound, best, best_sample, result);
#endif
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
        // (a literal true, compiled away, but for the single-pass bricked ray caster's jumps over
        // cells that are not drawn and its requests: bricks/paged_sampling.glsl)
        if (!next_occupied_sample(cursor, ray)) break;
        vec3 t = sample_point(ray, float(cursor.i));
        float value = intensity(t) * sample_weight(t);  // 0: masked (sample_weight.glsl)
        result.taken++;
        if (value > best) {
            best = value;
            best_sample = cursor.i;
#ifdef PAGED_MIP
            paged_best = best;  // the single pass skips blocks not above it (bricks/paged_sampling.glsl)
#endif
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
