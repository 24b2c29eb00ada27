#version 330
// BrickedRayCaster's last pass: the accumulated bricks -> the `image` and `depth` outputs of the
// RayCaster (raycasting/raycaster.frag.glsl). dvr and iso: the accumulated premultiplied colour
// over the background; mip: the accumulated maximum classified once (no opacity correction, no
// shading), sample 0 where nothing exceeded 0. Depth from the accumulated depth sample along the
// pixel's ray; its sample counter (b) is 0: the bricks do not count their samples.
// The components' GLSL (pixel ray, camera rays and depth output, transfer function, background) is
// included ahead of it (vgraph.bricks.sampling, RESOLVE_PARTS).

uniform sampler2D accumulated_sum;
uniform sampler2D accumulated_first;

layout(location = 0) out vec4 color;
layout(location = 1) out vec4 depth;

void main() {
    Ray ray;
    if (!pixel_ray(ray)) {
        color = background;
        depth = no_depth(0);
        return;
    }
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 sum = texelFetch(accumulated_sum, pixel, 0);
    vec4 first = texelFetch(accumulated_first, pixel, 0);
    Result result = empty_result();
#ifdef COMPOSITING_MIP
    vec4 classified = classify(sum.r);
    result.color = vec4(classified.rgb * classified.a, classified.a);
    result.depth_sample = sum.a > 0.0 ? sum.g : 0.0;
#else
    result.color = sum;
    result.depth_sample = first.a > 0.0 ? first.r : -1.0;
#endif
    color = over_background(result.color);
    depth = result_depth(ray, result);
}
