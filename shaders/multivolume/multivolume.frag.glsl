#version 330
// MultiVolumeRayCaster: one ray per pixel between the EntryExitPoints images of the first channel,
// CHANNELS volumes sampled at the same world points (channels.glsl), blended by exactly one of
// BLEND_ACCUMULATE, BLEND_NEAREST_OPAQUE, BLEND_MAXIMUM (only that one is compiled), shaded with
// SHADING_BLINN_PHONG (and LIGHT_HEADLIGHT).
//
// Outputs: `color` = the blended colour over `background`; `depth` as the RayCaster's.
//
// The MultiVolumeRayCaster's own part; its components' GLSL (pixel ray, camera rays and depth
// output, the channels' transfer functions, shading, background) is included ahead of it by
// RaycasterBase.draw.
#include "raycasting/sample_weight.glsl"
#include "multivolume/channels.glsl"
#include "multivolume/blend_accumulate.glsl"
#include "multivolume/blend_nearest_opaque.glsl"
#include "multivolume/blend_maximum.glsl"
#include "raycasting/ray_main.glsl"
