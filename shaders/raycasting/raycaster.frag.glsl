#version 330
// RayCaster (Inacio 2009 ch. 4.2.3): one ray per pixel between the EntryExitPoints images, composed
// from small parts; the defines the RayCaster chooses from its properties select the compositing
// mode (exactly one COMPOSITING_*), INTERPOLATION_NEAREST, SHADING_BLINN_PHONG with one GRADIENT_*
// and LIGHT_HEADLIGHT, and SKIP_EMPTY_SPACE. Code for features that are off is not compiled.
//
// Outputs: `color` = the composited colour over `background`; `depth` = (window-space depth in
// [0, 1] of the depth sample, its distance in world units from the ray's start on the near plane,
// the number of samples evaluated, 1) where there is a depth sample, else (1, 0, samples, 0).
#include "raycasting/ray.glsl"
#include "raycasting/pixel_ray.glsl"
#include "raycasting/depth_output.glsl"
#include "raycasting/background.glsl"
#include "raycasting/volume_sampling.glsl"
#include "raycasting/transfer_function.glsl"
#include "raycasting/gradients.glsl"
#include "raycasting/shading.glsl"
#include "raycasting/march.glsl"
#include "raycasting/compositing_dvr.glsl"
#include "raycasting/compositing_mip.glsl"
#include "raycasting/compositing_iso.glsl"
#include "raycasting/compositing_first_hit.glsl"
#include "raycasting/compositing_xray.glsl"

layout(location = 0) out vec4 color;
#ifdef DEPTH_OUTPUT
layout(location = 1) out vec4 depth;
#endif

void main() {
    Ray ray;
    if (!pixel_ray(ray)) {
        color = background;
#ifdef DEPTH_OUTPUT
        depth = no_depth(0);
#endif
        return;
    }
    Result result = march(ray);
    color = over_background(result.color);
#ifdef DEPTH_OUTPUT
    depth = result_depth(ray, result);
#endif
}
