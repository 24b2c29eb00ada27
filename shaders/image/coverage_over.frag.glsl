#version 330
// TextOverlay: `ink` (premultiplied RGBA) with the coverage in the red channel of `coverage`
// (text and scale bar rasterised on the CPU) "over" the image, as ImageCompositor composites.
#include "image/over.glsl"
uniform sampler2D image;
uniform sampler2D coverage;
uniform vec4 ink;
out vec4 color;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    color = over(ink * texelFetch(coverage, pixel, 0).r, texelFetch(image, pixel, 0));
}
