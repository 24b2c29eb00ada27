#version 330
// RayCaster (Inacio 2009 ch. 4.2.3): one ray per pixel between the EntryExitPoints images, composed
// from small parts; the defines the RayCaster chooses from its properties select the compositing
// mode (exactly one COMPOSITING_*), INTERPOLATION_NEAREST, SHADING_BLINN_PHONG with one GRADIENT_*
// and LIGHT_HEADLIGHT, and SKIP_EMPTY_SPACE. Code for features that are off is not compiled.
//
// Outputs: `color` = the composited colour over `background`; `depth` = (window-space depth in
// [0, 1] of the depth sample, its distance in world units from the ray's start on the near plane,
// the number of samples evaluated, 1) where there is a depth sample, else (1, 0, samples, 0).
#include "raycasting/ray.glsl"
#include "raycasting/volume_sampling.glsl"
#include "raycasting/transfer_function.glsl"
#include "raycasting/gradients.glsl"
#include "raycasting/shading.glsl"
#include "raycasting/march.glsl"
#include "raycasting/compositing_dvr.glsl"
#include "raycasting/compositing_mip.glsl"
#include "raycasting/compositing_iso.glsl"
#include "raycasting/compositing_first_hit.glsl"
#include "raycasting/compositing_xray.glsl"

uniform sampler2D entry_points;
uniform sampler2D exit_points;
uniform vec4 background;
uniform vec3 texture_to_world_offset;  // p = t * texture_to_world_scale + offset
uniform mat4 view_projection;
uniform vec2 viewport_size;
uniform vec3 near_centre;  // the pixel centre (ndc_x, ndc_y) is at near_centre + ndc_x near_right
uniform vec3 near_right;   // + ndc_y near_up on the near plane (where Camera.rays start)
uniform vec3 near_up;

layout(location = 0) out vec4 color;
layout(location = 1) out vec4 depth;

vec4 depth_output(vec3 t, int taken) {
    vec3 world = t * texture_to_world_scale + texture_to_world_offset;
    vec4 clip = view_projection * vec4(world, 1.0);
    vec2 ndc = gl_FragCoord.xy / viewport_size * 2.0 - 1.0;
    vec3 origin = near_centre + ndc.x * near_right + ndc.y * near_up;
    return vec4(clip.z / clip.w * 0.5 + 0.5, distance(world, origin), float(taken), 1.0);
}

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 entry_point = texelFetch(entry_points, pixel, 0);
    vec4 exit_point = texelFetch(exit_points, pixel, 0);
    if (entry_point.a == 0.0 || exit_point.a == 0.0) {
        color = background;
        depth = vec4(1.0, 0.0, 0.0, 0.0);
        return;
    }
    Ray ray = make_ray(entry_point.xyz, exit_point.xyz);
    Result result = march(ray);
    color = vec4(result.color.rgb + (1.0 - result.color.a) * background.rgb,
                 result.color.a + (1.0 - result.color.a) * background.a);
    depth = result.depth_sample >= 0.0
          ? depth_output(sample_point(ray, result.depth_sample), result.taken)
          : vec4(1.0, 0.0, float(result.taken), 0.0);
}
