// The outputs and main() of a ray caster whose parts define `Result march(Ray)`: the RayCaster's
// and the MultiVolumeRayCaster's. `color` = the composited colour over `background`; `depth` (with
// DEPTH_OUTPUT) = the depth output of depth_output.glsl. Include it last.
layout(location = 0) out vec4 color;
#ifdef DEPTH_OUTPUT
layout(location = 1) out vec4 depth;
#endif

void main() {
    Ray ray;
    if (!pixel_ray(ray)) {
        color = background;
#ifdef DEPTH_OUTPUT
        depth = no_depth(0);
#endif
        return;
    }
    Result result = march(ray);
    color = over_background(result.color);
#ifdef DEPTH_OUTPUT
    depth = result_depth(ray, result);
#endif
}
