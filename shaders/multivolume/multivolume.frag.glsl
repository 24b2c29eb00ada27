#version 330
// MultiVolumeRayCaster: one ray per pixel between the EntryExitPoints images of the first channel,
// CHANNELS volumes sampled at the same world points (channels.glsl), blended by exactly one of
// BLEND_ACCUMULATE, BLEND_NEAREST_OPAQUE, BLEND_MAXIMUM (only that one is compiled), shaded with
// SHADING_BLINN_PHONG (and LIGHT_HEADLIGHT). Rays, the depth output, shading and the background are
// the RayCaster's parts (raycasting/*.glsl).
//
// Outputs: `color` = the blended colour over `background`; `depth` as the RayCaster's.
#include "raycasting/ray.glsl"
#include "raycasting/pixel_ray.glsl"
#include "raycasting/depth_output.glsl"
#include "raycasting/background.glsl"
#include "raycasting/shading.glsl"
#include "multivolume/channels.glsl"
#include "multivolume/blend_accumulate.glsl"
#include "multivolume/blend_nearest_opaque.glsl"
#include "multivolume/blend_maximum.glsl"
#include "raycasting/ray_main.glsl"
