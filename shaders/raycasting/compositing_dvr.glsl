// COMPOSITING_DVR: direct volume rendering, front-to-back (Inacio 2009 eq. 2.3-2.4):
// C += (1 - A) a' rgb, A += (1 - A) a' with a' the opacity-corrected TF alpha, shaded colour where
// SHADING_BLINN_PHONG (only samples with a' > 0 are shaded: the others add nothing). The ray stops
// once A >= early_termination. Depth: the first sample with a' > 0. With SKIP_EMPTY_SPACE, regions
// of blocks where the TF has no opacity are jumped over (empty_space.glsl).
//
// With SKIP_EMPTY_SPACE the loops below look the block up only before every second to fourth
// sample, and take the samples between without asking: llvmpipe runs a loop's whole body for its 8
// lanes in every pass, so the look-up (and the jump code after it) cost as much at every sample as
// where a ray jumps. A sample taken in an empty block adds exactly nothing (every intensity its
// reconstruction can reach has TF opacity 0, empty_space.py), so the image and depth do not change;
// only the sample counter of the depth output counts the extra samples. More samples per look-up
// than these lost again (measured in docs/reports/performance.md); without skipping the plain loop
// is the fastest.
#include "raycasting/gradient_classification.glsl"  // classify_sample()
#ifdef COMPOSITING_DVR
uniform float early_termination;

// The sample after the current one: with PAGED_STRIDE (the single pass, bricks/paged_stride.glsl)
// the next one its cell's brick takes (a coarse level's lattice), each sample's opacity that of the
// level-0 steps it stands for; else the next.
#ifdef PAGED_STRIDE
#include "bricks/stepped_opacity.glsl"
#define NEXT_SAMPLE(cursor) cursor.i = stride_next(cursor.i)
#define SAMPLE_OPACITY(alpha, i) stepped_opacity(alpha, stride_next(i) - (i))
#else
#define NEXT_SAMPLE(cursor) ++cursor.i
#define SAMPLE_OPACITY(alpha, i) corrected_opacity(alpha)
#endif

// Sample i of the ray composited into sum; true once the ray is opaque enough to stop.
bool composited(Ray ray, int i, inout vec4 sum, inout Result result) {
    vec3 t = sample_point(ray, float(i));
    vec4 texel = shading_texel(t);  // raw value in .a (gradients.glsl)
    vec4 color = classify_sample(t, texel.a * intensity_scale + intensity_offset);  // gradient_classification.glsl
    color.a *= sample_weight(t);  // 0: masked or cut away (sample_weight.glsl)
    result.taken++;
    if (color.a > 0.0) {
        float alpha = SAMPLE_OPACITY(color.a, i);
#ifdef SHADING_BLINN_PHONG
        color.rgb = shade(color.rgb, texel_gradient(t, texel), -ray.direction);
#endif
#ifdef LIGHT_VOLUME
        color.rgb = shadowed(color.rgb, t);  // light_volume.glsl
#endif
        if (result.depth_sample < 0.0) {
            result.depth_sample = float(i);
        }
        float weight = (1.0 - sum.a) * alpha;
        sum += vec4(weight * color.rgb, weight);
        return sum.a >= early_termination;
    }
    return false;
}

#ifdef SHADING_BLINN_PHONG
// Whether sample i is visible (counted as taken when not: the main loop takes it again).
bool visible(Ray ray, int i, inout Result result) {
    vec3 t = sample_point(ray, float(i));
    if (classify_sample(t, intensity(t)).a * sample_weight(t) > 0.0) {
        return true;
    }
    result.taken++;
    return false;
}
#endif

#ifdef PAGED_SKIPPING
// The single pass (march.glsl's runs): a run's samples in a loop of their own, the look-up before
// it. llvmpipe runs a loop's body while one of its 8 lanes needs it: with a look-up and a sample
// in one body, the look-up ran in nearly every pass, whichever lane's run had ended; here the
// lanes whose runs end first wait, and their look-ups run together (bonsai dvr 69 -> 57 ms of
// CPU; docs/explanations/bricked-ray-casting.md). Composites the samples of the run from
// cursor.i on; true once the ray is opaque enough to stop.
bool composited_run(Ray ray, inout March cursor, inout vec4 sum, inout Result result) {
    int stop = run_stop(cursor, ray);
    while (cursor.i < stop) {
        if (composited(ray, cursor.i, sum, result)) return true;
        NEXT_SAMPLE(cursor);
    }
    return false;
}

#ifdef PAGED_WALK
// With the frame-wide grid (march.glsl's PAGED_WALK) the RayCaster's loop instead: up to 4 samples
// of the run per pass (2 shaded, as the RayCaster's), the grid asked again past each occupied block
// (so samples in a cell's empty blocks are jumped, not taken: bonsai dvr 81 -> 56 a pixel), the
// lanes in step. Cutting runs at blocks in composited_run's loop cost more loop heads than it saved
// samples; here a pass whose lane leaves its run early costs that lane at most 3 samples.
// Composites from cursor.i (in its run); true once the ray is opaque enough to stop.
bool composited_stretch(Ray ray, inout March cursor, inout vec4 sum, inout Result result) {
    int stop = run_stop(cursor, ray);
    if (composited(ray, cursor.i, sum, result)) return true;
    NEXT_SAMPLE(cursor);
    // (unrolled: the same within noise as a loop of 3 passes, bonsai 36 / 37 ms)
    if (cursor.i < stop) {
        if (composited(ray, cursor.i, sum, result)) return true;
        NEXT_SAMPLE(cursor);
    }
#ifndef SHADING_BLINN_PHONG
    if (cursor.i < stop) {
        if (composited(ray, cursor.i, sum, result)) return true;
        NEXT_SAMPLE(cursor);
    }
    if (cursor.i < stop) {
        if (composited(ray, cursor.i, sum, result)) return true;
        NEXT_SAMPLE(cursor);
    }
#endif
    return false;
}

#ifdef SHADING_BLINN_PHONG
// The same for the samples before the first visible one (3 a pass, as the RayCaster's): true at
// the first visible sample, left for the shading loop.
bool visible_stretch(Ray ray, inout March cursor, inout Result result) {
    int stop = run_stop(cursor, ray);
    if (visible(ray, cursor.i, result)) return true;
    NEXT_SAMPLE(cursor);
    if (cursor.i < stop) {
        if (visible(ray, cursor.i, result)) return true;
        NEXT_SAMPLE(cursor);
    }
    if (cursor.i < stop) {
        if (visible(ray, cursor.i, result)) return true;
        NEXT_SAMPLE(cursor);
    }
    return false;
}
#endif
#endif

#ifdef SHADING_BLINN_PHONG
// The same for the samples before the first visible one: true at the first visible sample (left
// for the shading loop). Only here: a shaded run's lanes waiting for the longest run cost more than
// their look-ups (torus 512^3: 291 -> 330 ms).
bool visible_in_run(Ray ray, inout March cursor, inout Result result) {
    int stop = run_stop(cursor, ray);
    while (cursor.i < stop) {
        if (visible(ray, cursor.i, result)) return true;
        NEXT_SAMPLE(cursor);
    }
    return false;
}
#endif
#endif

Result march(Ray ray) {
    Result result = empty_result();
    vec4 sum = vec4(0.0);
    March cursor = start_march(ray);
#ifdef SHADING_BLINN_PHONG
    // First the samples up to the first visible one, in a loop without the shading code: SIMD GL
    // runs a branch for a whole group of pixels when one of them takes it (a GPU's warp) or always
    // (llvmpipe's 8 lanes), so in a single loop rays still in empty space would pay for shading.
    while (cursor.i < ray.samples) {
#ifdef PAGED_WALK
        if (!next_occupied_sample(cursor, ray) || visible_stretch(ray, cursor, result)) break;
#elif defined(PAGED_SKIPPING)
        if (!next_occupied_sample(cursor, ray) || visible_in_run(ray, cursor, result)) break;
#else
        if (!next_occupied_sample(cursor, ray) || visible(ray, cursor.i, result)) break;
        NEXT_SAMPLE(cursor);
#endif
#ifdef SKIP_EMPTY_SPACE
        if (cursor.i >= ray.samples || visible(ray, cursor.i, result)) break;
        ++cursor.i;
        if (cursor.i >= ray.samples || visible(ray, cursor.i, result)) break;
        ++cursor.i;
#endif
    }
#endif
    while (cursor.i < ray.samples) {
#ifdef PAGED_WALK
        if (!next_occupied_sample(cursor, ray) || composited_stretch(ray, cursor, sum, result)) break;
#elif defined(PAGED_SKIPPING) && !defined(SHADING_BLINN_PHONG)
        if (!next_occupied_sample(cursor, ray) || composited_run(ray, cursor, sum, result)) break;
#else
        if (!next_occupied_sample(cursor, ray) || composited(ray, cursor.i, sum, result)) break;
        NEXT_SAMPLE(cursor);
#endif
#ifdef SKIP_EMPTY_SPACE
        if (cursor.i >= ray.samples || composited(ray, cursor.i, sum, result)) break;
        ++cursor.i;
#ifndef SHADING_BLINN_PHONG  // a shaded sample costs more: one more per look-up only
        if (cursor.i >= ray.samples || composited(ray, cursor.i, sum, result)) break;
        ++cursor.i;
        if (cursor.i >= ray.samples || composited(ray, cursor.i, sum, result)) break;
        ++cursor.i;
#endif
#endif
    }
    result.color = sum;
    return result;
}
#endif
