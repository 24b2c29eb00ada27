// READ_ACCUMULATION (dvr with early termination): what the bricks in front of this one left at
// this pixel, read from the accumulation this pass does not draw to (the processor draws into a
// scratch pair and copies the brick's rectangle back, copy.frag.glsl): the premultiplied sum and
// the first depth sample (-1: none yet).
#ifdef READ_ACCUMULATION
uniform sampler2D front_sum;
uniform sampler2D front_first;

void front_state(out vec4 sum, out float depth_sample) {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    sum = texelFetch(front_sum, pixel, 0);
    vec4 first = texelFetch(front_first, pixel, 0);
    depth_sample = first.a > 0.0 ? first.r : -1.0;
}
#else
void front_state(out vec4 sum, out float depth_sample) {
    sum = vec4(0.0);
    depth_sample = -1.0;
}
#endif
