#version 330
// Entry and exit points cut at an opaque surface (Voreen's EEPGeometryIntegrator): where the
// surface's depth (a GeometryRenderer's depth image, g = distance in world units from the
// pixel's ray start on the near plane) lies before the entry point the ray is emptied (alpha 0:
// the ray caster shows its background there); between entry and exit the exit point moves onto
// the surface, on the line from entry to exit (so a jittered entry keeps its ray); beyond the
// exit nothing changes.
uniform sampler2D entry_points;
uniform sampler2D exit_points;
uniform sampler2D geometry_depth;
uniform vec3 texture_to_world_scale;  // p = t * scale + offset (vgraph.gl.raycasting.geometry)
uniform vec3 texture_to_world_offset;
// Camera.rays: the pixel centre (ndc_x, ndc_y) starts at near_point(ndc) (pixel_depth.glsl; also
// world_length, world units per unit of the frame the rays are in: framed_view) in direction
// ray_direction(ndc) (pixel_direction.glsl; not normalised).
#include "raycasting/pixel_direction.glsl"

layout(location = 0) out vec4 entry_out;
layout(location = 1) out vec4 exit_out;

float along_ray(vec3 t, vec3 origin, vec3 direction) {
    return dot(t * texture_to_world_scale + texture_to_world_offset - origin, direction);
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 entry_point = texelFetch(entry_points, pixel, 0);
    vec4 exit_point = texelFetch(exit_points, pixel, 0);
    vec4 surface = texelFetch(geometry_depth, pixel, 0);
    entry_out = entry_point;
    exit_out = exit_point;
    if (entry_point.a == 0.0 || exit_point.a == 0.0 || surface.a == 0.0) {
        return;
    }
    vec2 ndc = pixel_ndc();  // pixel_offset stays 0: the rays are this image's own (ray_uniforms)
    vec3 origin = near_point(ndc);
    vec3 direction = normalize(ray_direction(ndc));
    float entry_t = along_ray(entry_point.xyz, origin, direction);
    float exit_t = along_ray(exit_point.xyz, origin, direction);
    float surface_t = surface.g / world_length;
    if (surface_t <= entry_t) {
        entry_out = vec4(0.0);
        exit_out = vec4(0.0);
    } else if (surface_t < exit_t) {
        exit_out = vec4(mix(entry_point.xyz, exit_point.xyz, (surface_t - entry_t) / (exit_t - entry_t)), 1.0);
    }
}
