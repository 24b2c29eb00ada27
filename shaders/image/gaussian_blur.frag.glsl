#version 330
// ImageBlur's pass: one axis of the Gaussian over all four channels (premultiplied colour and
// alpha blur alike, so a transparent background stays transparent). Two passes make the 2D blur.
#include "image/edge_texel.glsl"
#include "image/gaussian_pass.glsl"
uniform sampler2D image;
out vec4 color;

void main() {
    color = gaussian_along(image, ivec2(gl_FragCoord.xy));
}
