#version 330
// CurvatureVolumeRaycaster (Cabral 2010 sec. 5.5): direct volume rendering between the EntryExitPoints
// images with opacity from the transfer function and colour from curvature
// (compositing_curvature.glsl). Composed from the RayCaster's parts (ray set-up, volume sampling,
// transfer function, empty-space skipping, shading) and the curvature parts; the defines choose
// exactly one field (DERIVATIVES_*), one measure (CURVATURE_*), the normalisation
// (NORMALIZATION_*), RANGE_PASS, OPACITY_CORRECTION, SHADING_BLINN_PHONG with LIGHT_HEADLIGHT and
// SKIP_EMPTY_SPACE. Code for what is off is not compiled.
//
// Outputs: `color` = the composited colour over `background` (RANGE_PASS: the range of the
// measure, see compositing_curvature.glsl); `depth` = the RayCaster's depth output at the first
// sample with opacity > 0 (else (1, 0, samples, 0)).
//
// Its own part; the GLSL of its components (pixel ray, camera rays and depth output, volume
// sampling, transfer function, curvature field and colouring, empty space, background, shading)
// is included ahead of it by RaycasterBase.draw.
#include "raycasting/sample_weight.glsl"
#include "raycasting/march.glsl"
#include "curvature/compositing_curvature.glsl"

layout(location = 0) out vec4 color;
layout(location = 1) out vec4 depth;

void main() {
    Ray ray;
    if (!pixel_ray(ray)) {
#ifdef RANGE_PASS
        color = vec4(3.0e38, -3.0e38, 0.0, 1.0);
#else
        color = background;
#endif
        depth = no_depth(0);
        return;
    }
    Result result = march(ray);
#ifdef RANGE_PASS
    color = result.color;
#else
    color = over_background(result.color);
#endif
    depth = result_depth(ray, result);
}
