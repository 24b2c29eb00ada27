// The direction of the pixel's ray, for every pass that follows the pixels' rays
// (entry_exit_point.glsl, ray_bounds.frag.glsl, geometry/geometry_entry_exit.frag.glsl,
// tetrahedra/cells.frag.glsl); where it starts: pixel_depth.glsl (Camera.rays, bound with these
// by vgraph.gl.raycasting.geometry.pixel_rays).
#include "raycasting/pixel_depth.glsl"
uniform vec3 direction_centre;  // given apart from the points: near_point - eye would lose
uniform vec3 direction_right;   // digits when the near plane is close to the eye
uniform vec3 direction_up;

// The direction of the ray of the pixel centre at ``ndc``: not normalised, its component along the
// view direction is 1 (so the far plane is at ray parameter far - near).
vec3 ray_direction(vec2 ndc) {
    return direction_centre + ndc.x * direction_right + ndc.y * direction_up;
}

// 1 / direction per axis for slab tests: a ray parallel to a slab is inside it for all or no t, so a
// huge 1/d gives +-huge or 0 there.
vec3 inverse_direction(vec3 direction) {
    return vec3(direction.x != 0.0 ? 1.0 / direction.x : 1e30,
                direction.y != 0.0 ? 1.0 / direction.y : 1e30,
                direction.z != 0.0 ? 1.0 / direction.z : 1e30);
}
