// The depth output of every ray caster (docs/explanations/ray-casting.md): (window-space depth in [0, 1] of the
// depth sample, its distance in world units from the ray's start on the near plane, the number of
// samples evaluated, 1); (1, 0, samples, 0) where there is none. Needs ray.glsl.
uniform vec3 texture_to_world_offset;  // p = t * texture_to_world_scale + offset (ray.glsl)
uniform mat4 view_projection;
uniform vec2 viewport_size;  // of the whole picture; pixel_offset: this image's place in it
uniform vec2 pixel_offset;   // (geometry.pixel_rays: a tile's rays are the whole picture's)
uniform vec3 near_centre;  // the pixel centre (ndc_x, ndc_y) is at near_centre + ndc_x near_right
uniform vec3 near_right;   // + ndc_y near_up on the near plane (where Camera.rays start)
uniform vec3 near_up;
uniform float world_length;  // world units per unit of the frame the volume is drawn in (an
                             // extreme box's normalised frame, framed_view; else 1)

vec3 world_point(vec3 t) {
    return t * texture_to_world_scale + texture_to_world_offset;
}

vec4 depth_of(vec3 world, int taken) {
    vec4 clip = view_projection * vec4(world, 1.0);
    vec2 ndc = (gl_FragCoord.xy + pixel_offset) / viewport_size * 2.0 - 1.0;
    vec3 origin = near_centre + ndc.x * near_right + ndc.y * near_up;
    return vec4(clip.z / clip.w * 0.5 + 0.5, distance(world, origin) * world_length, float(taken), 1.0);
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
