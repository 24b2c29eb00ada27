// The crossing of the iso level between two samples (COMPOSITING_ISO of the RayCaster and of the
// BrickedRayCaster): ISO_REFINEMENT regula-falsi steps, one volume sample each, then a final linear
// interpolation. Needs ray.glsl's Ray and sample_point() and an intensity().
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
