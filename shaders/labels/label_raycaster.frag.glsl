#version 330
// LabelRayCaster: one ray per pixel between the EntryExitPoints images through a label volume,
// labels reconstructed by the majority of interpolation weights (majority.glsl), coloured by the
// label table. Defines: exactly one COMPOSITING_* (COMPOSITE, FIRST_HIT), SHADING_BLINN_PHONG with
// LIGHT_HEADLIGHT, SKIP_EMPTY_SPACE and RAY_BOUNDS (over blocks without shown labels). Output:
// premultiplied colour over `background`; with DEPTH_OUTPUT also the depth output
// (raycasting/depth_output.glsl) at `depth_sample`, which the compositing modes set to the first
// sample whose label is shown (-1: none).
//
// The LabelRayCaster's own part; its components' GLSL (pixel ray, camera rays and depth output,
// shading, empty space and ray bounds, background) is included ahead of it by RaycasterBase.draw.
float depth_sample = -1.0;  // set by march(): the ray parameter of the depth output's sample

#include "raycasting/sample_weight.glsl"
#include "raycasting/march.glsl"
#include "labels/majority.glsl"
#include "labels/label_shading.glsl"
#include "labels/compositing_composite.glsl"
#include "labels/compositing_first_hit.glsl"

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
    color = over_background(march(ray));
#ifdef DEPTH_OUTPUT
    depth = depth_sample >= 0.0 ? depth_of(world_point(sample_point(ray, depth_sample)), 0) : no_depth(0);
#endif
}
