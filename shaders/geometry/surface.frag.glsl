#version 330
// An opaque surface: its colour (surface_color.glsl), lit with the ray casters' Blinn-Phong model
// (raycasting/shading.glsl, two-sided), and a depth image in the RayCaster's convention
// (docs/explanations/ray-casting.md, "The depth output"): r = window depth, g = distance in world units from the
// pixel's ray start on the near plane, b = 0, a = 1. The GL depth test keeps the nearest surface.
#include "geometry/surface_color.glsl"
#include "raycasting/shading.glsl"
// The pixel's ray start (pixel_ndc, near_point) and world_length: units of the drawn geometry
// (one drawn in its box's normalised frame, vgraph.box_frame; else 1).
#include "raycasting/pixel_depth.glsl"

#ifdef PROJECTION_PERSPECTIVE
uniform vec3 eye;
#else
uniform vec3 view_forward;
#endif

in vec3 world;
in vec3 world_normal;
in vec4 color_in;
in float scalar_in;
layout(location = 0) out vec4 color;
layout(location = 1) out vec4 depth;

void main() {
    vec3 rgb = surface_color(color_in, scalar_in);
#ifdef SHADING_BLINN_PHONG
#ifdef PROJECTION_PERSPECTIVE
    vec3 towards_viewer = normalize(eye - world);
#else
    vec3 towards_viewer = -view_forward;
#endif
    rgb = shade(rgb, world_normal, towards_viewer);
#endif
    color = vec4(rgb, 1.0);
    // The rasterised depth, not point_depth's from view_projection: the GL depth test compares it.
    depth = vec4(gl_FragCoord.z, distance(world, near_point(pixel_ndc())) * world_length, 0.0, 1.0);
}
