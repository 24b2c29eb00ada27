// RAY_BOUNDS (vgraph.gl.raycasting.ray_bounds): the bounds pass's texel of the pixel's tile holds
// (nearest entry, -farthest exit) of the tile's rays in occupied blocks, as depth from the near
// plane (the parameter s of Camera.rays, whose direction has component 1 along the view), FAR where
// no ray of the tile meets an occupied block. pixel_ray() returns false there (the background, no
// depth sample, nothing evaluated); march.glsl's start_march() keeps the samples within one step of
// the bounds.
#ifdef RAY_BOUNDS
uniform sampler2D ray_bounds;
uniform int ray_bounds_tile;  // pixels per texel and axis

vec2 pixel_bounds() {
    return texelFetch(ray_bounds, ivec2(gl_FragCoord.xy) / ray_bounds_tile, 0).xy;
}

bool meets_occupied_block() {
    return pixel_bounds().x < 1e29;
}
#endif
