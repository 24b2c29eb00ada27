// COMPOSITING_ISO: the first point where the normalised intensity reaches `iso_level`. The first
// sample with value >= level is found, then the crossing between it and the sample before is refined
// by ISO_REFINEMENT regula-falsi steps (one volume sample each) and a final linear interpolation.
// (If sample 0 already reaches the level, the surface is cut by the box or the near plane and the
// hit is sample 0.) Colour: TF(iso_level).rgb, shaded at the hit with SHADING_BLINN_PHONG, opaque.
// Depth: the refined hit. With SKIP_EMPTY_SPACE, regions of blocks whose maximum is below the level
// are jumped over; the sample before a hit is then fetched again for the refinement.
#ifdef COMPOSITING_ISO
#include "raycasting/iso_refinement.glsl"

// Sample i: its value, and whether it is the hit: at or above the level and neither masked nor cut
// away (weight below 1/2, sample_weight.glsl; after such a sample the hit is the sample itself: the
// surface is cut there).
bool is_hit(Ray ray, int i, out float value, inout Result result) {
    value = intensity(sample_point(ray, float(i)));
    result.taken++;
    return value >= iso_level && sample_weight(sample_point(ray, float(i))) >= 0.5;
}

Result march(Ray ray) {
    Result result = empty_result();
    float previous = 0.0;
    bool have_previous = false;  // false after a skip: the sample before was not evaluated
    float value = 0.0;
    bool hit_found = false;
#ifdef PAGED_ISO_GRID
    // the single pass in a complete frame of level-0 bricks: the RayCaster's loop over its blocks,
    // whose texels say where to read (march.glsl's iso_grid_skip)
    BlockWalk walk = block_walk(ray);
    int i = 0;
    while (i < ray.samples) {
        if (iso_grid_skip(walk, i, ray.samples)) {
            have_previous = false;
            if (i >= ray.samples) break;
        }
        if (is_hit(ray, i, value, result)) {
            hit_found = true;
            break;
        }
        previous = value;
        have_previous = true;
        ++i;
    }
    March cursor;
    cursor.i = i;
#else
    March cursor = start_march(ray);
    // The loop only finds the first sample at or above the level; the refinement and the shading
    // come after it: llvmpipe runs an `if` body in a loop in every pass for all 8 lanes, and they
    // cost several samples (the single pass's bonsai iso 57 -> 41 ms of CPU, the RayCaster's the same).
    while (cursor.i < ray.samples) {
        if (skip_empty_space(cursor, ray)) {
            have_previous = false;
            if (cursor.i >= ray.samples) break;
        }
#ifdef PAGED_SKIPPING
        // the single pass: the run's samples in a loop of their own, as compositing_dvr.glsl's
        // composited_run (bonsai iso 42 -> 35 ms)
        int stop = run_stop(cursor, ray);
        while (cursor.i < stop && !(hit_found = is_hit(ray, cursor.i, value, result))) {
            previous = value;
            have_previous = true;
            ++cursor.i;
        }
        if (hit_found) break;
#else
        if (is_hit(ray, cursor.i, value, result)) {
            hit_found = true;
            break;
        }
        previous = value;
        have_previous = true;
        ++cursor.i;
#endif
    }
#endif
    if (hit_found) {
        int i = cursor.i;
        float hit = float(i);
        if (i > 0 && sample_weight(sample_point(ray, float(i - 1))) >= 0.5) {
            float before = have_previous ? previous : intensity(sample_point(ray, float(i - 1)));
            hit = refine_crossing(ray, float(i - 1), before - iso_level, hit, value - iso_level);
        }
        result.color = vec4(iso_surface_colour(ray, hit), 1.0);
        result.depth_sample = hit;
    }
    return result;
}
#endif
