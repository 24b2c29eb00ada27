// RAY_BOUNDS (vgraph.gl.raycasting.ray_bounds): the samples of the pixel's ray that may lie in an
// occupied block, from the bounds pass's texel of the pixel's tile: (nearest entry, -farthest exit)
// as depth from the near plane (the parameter s of Camera.rays, whose direction has component 1
// along the view), FAR where no ray of the tile meets an occupied block. Samples keep their
// positions start + i * step; only samples in empty blocks are left out, with one step to spare on
// each side for rounding, so the image does not change. Needs ray.glsl and depth_output.glsl.
#ifdef RAY_BOUNDS
uniform sampler2D ray_bounds;
uniform int ray_bounds_tile;  // pixels per texel and axis

// The first sample to evaluate; lowers ray.samples past the last one (to 0 where nothing is
// occupied along the ray, which then shows the background without sampling).
int bound_samples(inout Ray ray) {
    vec2 bounds = texelFetch(ray_bounds, ivec2(gl_FragCoord.xy) / ray_bounds_tile, 0).xy;
    if (bounds.x > 1e29) {
        ray.samples = 0;
        return 0;
    }
    float start = dot(world_point(ray.start) - near_centre, view_forward);
    float per_sample = step_length * dot(ray.direction, view_forward);
    float first = floor((bounds.x - start) / per_sample) - 1.0;
    float last = ceil((-bounds.y - start) / per_sample) + 1.0;
    ray.samples = int(clamp(last + 1.0, 0.0, float(ray.samples)));
    return int(clamp(first, 0.0, float(ray.samples)));
}
#endif
