#version 330
// ImageThreshold: a binary image, `above` where the chosen value (image/channel_value.glsl) is at
// least `threshold`, else `below` (both premultiplied RGBA).
#include "image/luminance.glsl"
#include "image/channel_value.glsl"
uniform sampler2D image;
uniform float threshold;
uniform vec4 above;
uniform vec4 below;
out vec4 color;

void main() {
    float value = channel_value(texelFetch(image, ivec2(gl_FragCoord.xy), 0));
    color = value >= threshold ? above : below;
}
