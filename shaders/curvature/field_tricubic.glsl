// The field of the tricubic modes (DERIVATIVES_TRICUBIC; with TRICUBIC_FAST the Sigg-Hadwiger
// variant): the cubic B-spline of a COEFFICIENT volume (CubicSplineProcessor output) bound as
// `volume`, with exact value, gradient and Hessian from tricubic/tricubic.glsl (docs/explanations/tricubic.md).
// The hit search marches on the 8-fetch fast value (on llvmpipe equal to the direct sum to ~1e-6
// of the range) and refines the crossing with field_value(), the selected variant's own value, so
// the hit lies on the level set of the very spline whose derivatives give the curvature.
// The fast form needs a LINEAR sampler on `volume` (bound by the processors); texelFetch in the
// direct form ignores it. Everything here is compiled only with DERIVATIVES_TRICUBIC.
#ifdef DERIVATIVES_TRICUBIC
#include "tricubic/tricubic.glsl"

uniform vec3 inv_spacing;  // 1 / spacing (x, y, z)

float march_value(vec3 t) {
    return tricubic_fast_value_voxel(volume, tricubic_voxel_coordinate(volume, t));
}

float field_value(vec3 t) {
    return tricubic_value(volume, t);
}

// Gradient (normalised intensity per world unit) and Hessian (per world unit squared) at t.
void field_derivatives(vec3 t, out vec3 g, out mat3 h) {
    float value;
    tricubic_jet(volume, t, value, g, h);
    tricubic_world_derivatives(inv_spacing, g, h);
    g *= intensity_scale;
    h *= intensity_scale;
}
#endif
