#version 330
// Ray bounds (vgraph.gl.raycasting.ray_bounds): the part of the tile's centre ray (Camera.rays:
// origin on the near plane, parameter s = depth from it, clipped to [0, far - near]) inside this
// fragment's box, as (enter, -leave); the target blends with MIN, so it ends up holding the nearest
// entry and the farthest exit over all boxes. Rays that miss the box are discarded.
// The ray of a point (ndc_x, ndc_y) of the whole picture starts at near_point(ndc) (pixel_depth.glsl,
// geometry.pixel_rays: a tile's too).
#include "raycasting/pixel_depth.glsl"
uniform int ray_bounds_tile;    // pixels per tile and axis
uniform vec3 direction_centre;  // its direction (component 1 along the view): direction_centre
uniform vec3 direction_right;   // + ndc_x * direction_right + ndc_y * direction_up
uniform vec3 direction_up;
uniform float near_to_far;      // far - near

flat in vec3 lo;
flat in vec3 hi;

layout(location = 0) out vec2 bounds;

void main() {
    vec2 ndc = picture_ndc(gl_FragCoord.xy * float(ray_bounds_tile));  // the tile's centre
    vec3 origin = near_point(ndc);
    vec3 direction = direction_centre + ndc.x * direction_right + ndc.y * direction_up;
    vec3 inverse = vec3(direction.x != 0.0 ? 1.0 / direction.x : 1e30,
                        direction.y != 0.0 ? 1.0 / direction.y : 1e30,
                        direction.z != 0.0 ? 1.0 / direction.z : 1e30);
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
