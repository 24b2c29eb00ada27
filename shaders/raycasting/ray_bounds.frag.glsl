#version 330
// Ray bounds (vgraph.gl.raycasting.ray_bounds): the part of the tile's centre ray (Camera.rays:
// origin on the near plane, parameter s = depth from it, clipped to [0, far - near]) inside this
// fragment's box, as (enter, -leave); the target blends with MIN, so it ends up holding the nearest
// entry and the farthest exit over all boxes. Rays that miss the box are discarded.
// The ray of a point (ndc_x, ndc_y) of the whole picture starts at near_point(ndc) (pixel_depth.glsl,
// geometry.pixel_rays: a tile's too) along ray_direction(ndc) (pixel_direction.glsl).
#include "raycasting/pixel_direction.glsl"
uniform int ray_bounds_tile;    // pixels per tile and axis
uniform float near_to_far;      // far - near

flat in vec3 lo;
flat in vec3 hi;

layout(location = 0) out vec2 bounds;

void main() {
    vec2 ndc = picture_ndc(gl_FragCoord.xy * float(ray_bounds_tile));  // the tile's centre
    vec3 origin = near_point(ndc);
    vec3 inverse = inverse_direction(ray_direction(ndc));
    vec3 t0 = (lo - origin) * inverse;
    vec3 t1 = (hi - origin) * inverse;
    vec3 near_t = min(t0, t1);
    vec3 far_t = max(t0, t1);
    float enter = max(max(max(near_t.x, near_t.y), near_t.z), 0.0);
    float leave = min(min(min(far_t.x, far_t.y), far_t.z), near_to_far);
    if (leave < enter) {
        discard;
    }
    bounds = vec2(enter, -leave);
}
