// The depth output of every ray caster (docs/explanations/ray-casting.md): (window-space depth in [0, 1] of the
// depth sample, its distance in world units from the ray's start on the near plane, the number of
// samples evaluated, 1); (1, 0, samples, 0) where there is none. Needs ray.glsl.
#include "raycasting/pixel_depth.glsl"
uniform vec3 texture_to_world_offset;  // p = t * texture_to_world_scale + offset (ray.glsl)

vec3 world_point(vec3 t) {
    return t * texture_to_world_scale + texture_to_world_offset;
}

vec4 depth_of(vec3 world, int taken) {
    return point_depth(world, near_point(pixel_ndc()), float(taken));
}

vec4 no_depth(int taken) {
    return vec4(1.0, 0.0, float(taken), 0.0);
}

// The depth output of a compositing Result (ray.glsl) along its ray.
vec4 result_depth(Ray ray, Result result) {
    return result.depth_sample >= 0.0
         ? depth_of(world_point(sample_point(ray, result.depth_sample)), result.taken)
         : no_depth(result.taken);
}
