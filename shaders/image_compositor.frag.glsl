#version 330
// Two premultiplied RGBA images of one size into one: MODE_OVER the Porter-Duff "over"
// (front + (1 - front.a) back, the ray casters' front-to-back rule), MODE_ADD their sum, clamped
// to [0, 1] (glows, overlays that only add light).
#include "image/over.glsl"
uniform sampler2D front;
uniform sampler2D back;
out vec4 color;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 a = texelFetch(front, pixel, 0);
    vec4 b = texelFetch(back, pixel, 0);
#ifdef MODE_ADD
    color = clamp(a + b, 0.0, 1.0);
#else
    color = over(a, b);
#endif
}
