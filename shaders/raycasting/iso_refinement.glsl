// The crossing of the iso level between two samples (COMPOSITING_ISO of the RayCaster and of the
// BrickedRayCaster): ISO_REFINEMENT regula-falsi steps, one volume sample each, then a final linear
// interpolation; and the surface's colour there. Needs ray.glsl's Ray and sample_point(), an
// intensity(), classify() and, with SHADING_BLINN_PHONG, shade(), gradient() and raw_sample().
#define ISO_REFINEMENT 3
uniform float iso_level;

// a < b are fractional sample indices with value(a) - level = fa < 0 <= fb = value(b) - level.
float refine_crossing(Ray ray, float a, float fa, float b, float fb) {
    for (int k = 0; k < ISO_REFINEMENT; ++k) {
        float middle = a + (b - a) * fa / (fa - fb);
        float fm = intensity(sample_point(ray, middle)) - iso_level;
        if (fm >= 0.0) {
            b = middle;
            fb = fm;
        } else {
            a = middle;
            fa = fm;
        }
    }
    return a + (b - a) * fa / (fa - fb);
}

// The iso-surface's colour at fractional sample `hit`: TF(iso_level).rgb, lit there with
// SHADING_BLINN_PHONG.
vec3 iso_surface_colour(Ray ray, float hit) {
    vec3 rgb = classify(iso_level).rgb;
#ifdef SHADING_BLINN_PHONG
    vec3 p = sample_point(ray, hit);
#ifdef PAGED_SKIPPING
    paged_seat(p);  // the single-pass bricked ray caster: the hit's own cell (bricks/paged_sampling.glsl)
#endif
    rgb = shade(rgb, gradient(p, raw_sample(p)), -ray.direction);
#endif
#ifdef LIGHT_VOLUME
    rgb = shadowed(rgb, sample_point(ray, hit));  // light_volume.glsl
#endif
    return rgb;
}
