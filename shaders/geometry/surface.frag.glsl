#version 330
// An opaque surface: its colour (surface_color.glsl), lit with the ray casters' Blinn-Phong model
// (raycasting/shading.glsl, two-sided), and a depth image in the RayCaster's convention
// (docs/explanations/ray-casting.md, "The depth output"): r = window depth, g = distance in world units from the
// pixel's ray start on the near plane, b = 0, a = 1. The GL depth test keeps the nearest surface.
#include "geometry/surface_color.glsl"
#include "raycasting/shading.glsl"

uniform vec2 viewport_size;  // of the whole picture; pixel_offset: this image's place in it
uniform vec2 pixel_offset;   // (geometry.pixel_rays: a tile's rays are the whole picture's)
uniform vec3 near_centre;  // the pixel centre (ndc_x, ndc_y) is at near_centre + ndc_x near_right
uniform vec3 near_right;   // + ndc_y near_up on the near plane (where Camera.rays start)
uniform vec3 near_up;
uniform float world_length;  // world units per unit of the drawn geometry (one drawn in its box's
                             // normalised frame, vgraph.box_frame; else 1)
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
    vec2 ndc = (gl_FragCoord.xy + pixel_offset) / viewport_size * 2.0 - 1.0;
    vec3 origin = near_centre + ndc.x * near_right + ndc.y * near_up;
    depth = vec4(gl_FragCoord.z, distance(world, origin) * world_length, 0.0, 1.0);
}
