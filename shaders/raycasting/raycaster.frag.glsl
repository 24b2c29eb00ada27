#version 330
// RayCaster (Inacio 2009 ch. 4.2.3): one ray per pixel between the EntryExitPoints images, composed
// from small parts; the defines the RayCaster chooses from its properties select the compositing
// mode (exactly one COMPOSITING_*), INTERPOLATION_NEAREST, SHADING_BLINN_PHONG with one GRADIENT_*
// and LIGHT_HEADLIGHT, and SKIP_EMPTY_SPACE. Code for features that are off is not compiled.
//
// Outputs: `color` = the composited colour over `background`; `depth` = (window-space depth in
// [0, 1] of the depth sample, its distance in world units from the ray's start on the near plane,
// the number of samples evaluated, 1) where there is a depth sample, else (1, 0, samples, 0).
//
// The RayCaster's own part; its components' GLSL (pixel ray, camera rays and depth output, volume
// sampling, transfer function, gradients, shading, empty space, background) is included ahead of
// it by RaycasterBase.draw.
#include "raycasting/sample_weight.glsl"
#include "raycasting/march.glsl"
#include "raycasting/compositing_dvr.glsl"
#include "raycasting/compositing_mip.glsl"
#include "raycasting/compositing_iso.glsl"
#include "raycasting/compositing_first_hit.glsl"
#include "raycasting/compositing_xray.glsl"
#include "raycasting/ray_main.glsl"
