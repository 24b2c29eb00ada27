#version 330
// BrickedRayCaster with READ_ACCUMULATION: copy a brick's rectangle (the scissor) of the scratch
// targets back into the accumulation, so the next brick reads what this one left.
uniform sampler2D scratch_sum;
uniform sampler2D scratch_first;

layout(location = 0) out vec4 sum;
layout(location = 1) out vec4 first;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    sum = texelFetch(scratch_sum, pixel, 0);
    first = texelFetch(scratch_first, pixel, 0);
}
