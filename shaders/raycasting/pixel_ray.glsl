// The pixel's ray between the EntryExitPoints images (texture coordinates; alpha 0 where the
// pixel's ray misses the volume's box). With RAY_BOUNDS, also none where the ray meets no
// occupied block (ray_bounds.glsl): such pixels show the background.
#include "raycasting/ray.glsl"
#include "raycasting/ray_bounds.glsl"
uniform sampler2D entry_points;
uniform sampler2D exit_points;

bool pixel_ray(out Ray ray) {
#ifdef RAY_BOUNDS
    if (!meets_occupied_block()) {
        return false;
    }
#endif
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 entry_point = texelFetch(entry_points, pixel, 0);
    vec4 exit_point = texelFetch(exit_points, pixel, 0);
    if (entry_point.a == 0.0 || exit_point.a == 0.0) {
        return false;
    }
    ray = make_ray(entry_point.xyz, exit_point.xyz);
    return true;
}
