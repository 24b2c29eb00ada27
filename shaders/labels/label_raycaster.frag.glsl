#version 330
// LabelRayCaster: one ray per pixel between the EntryExitPoints images through a label volume,
// labels reconstructed by the majority of interpolation weights (majority.glsl), coloured by the
// label table. Defines: exactly one COMPOSITING_* (COMPOSITE, FIRST_HIT), SHADING_BLINN_PHONG with
// LIGHT_HEADLIGHT, SKIP_EMPTY_SPACE and RAY_BOUNDS (over blocks without shown labels). Output:
// premultiplied colour over `background`.
//
// The LabelRayCaster's own part; its components' GLSL (pixel ray, camera rays and depth output,
// shading, empty space and ray bounds, background) is included ahead of it by RaycasterBase.draw.
#include "raycasting/march.glsl"
#include "labels/majority.glsl"
#include "labels/label_shading.glsl"
#include "labels/compositing_composite.glsl"
#include "labels/compositing_first_hit.glsl"

layout(location = 0) out vec4 color;

void main() {
    Ray ray;
    if (!pixel_ray(ray)) {
        color = background;
        return;
    }
    color = over_background(march(ray));
}
