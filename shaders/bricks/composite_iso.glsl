// COMPOSITING_ISO in one brick: the RayCaster's first hit (raycasting/compositing_iso.glsl) among
// the samples the brick owns. The sample before a hit may belong to the brick in front; it is
// evaluated here through the halo (exact while a step is at most one voxel: sampling_rate >= 1).
// The opaque result blends under the bricks in front, so the frontmost hit wins.
#ifdef COMPOSITING_ISO
#include "raycasting/iso_refinement.glsl"

void composite(Ray ray, Span span, inout vec4 sum, inout float depth_sample) {  // (starts at 0)
    sum = vec4(0.0);
    depth_sample = -1.0;
    for (int i = span.first; i <= span.last; ++i) {
        vec3 t = sample_point(ray, float(i));
        if (!owns(t)) {
            continue;
        }
        SKIP_BLOCK_IF(ray, t, i, range.y < iso_level)  // (the sample before a hit is fetched anyway)
        float value = intensity(t);
        // A masked or cut-away sample (weight below 1/2) is no hit; after one, the hit is the
        // sample itself: the surface is cut there (as raycasting/compositing_iso.glsl).
        if (value >= iso_level && sample_weight(t) >= 0.5) {
            float hit = float(i);
            if (i > 0 && sample_weight(sample_point(ray, float(i - 1))) >= 0.5) {
                float before = intensity(sample_point(ray, float(i - 1)));
                hit = refine_crossing(ray, float(i - 1), before - iso_level, hit, value - iso_level);
            }
            sum = vec4(iso_surface_colour(ray, hit), 1.0);
            depth_sample = hit;
            return;
        }
    }
}
#endif
