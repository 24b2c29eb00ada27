#version 330
// Grayscale (Cabral 2010, code 4.5): luminance 0.30 R + 0.59 G + 0.11 B, mixed with the original
// colour by `saturation` (0 = grey, 1 = unchanged). Alpha is kept.
#include "image/luminance.glsl"
uniform sampler2D image;
uniform float saturation;
out vec4 color;

void main() {
    // texelFetch, not texture(): the output has the input's size, so each pixel reads exactly its
    // own texel and no filtering can blur neighbours into it.
    vec4 original = texelFetch(image, ivec2(gl_FragCoord.xy), 0);
    color = vec4(mix(vec3(luminance(original.rgb)), original.rgb, saturation), original.a);
}
