#version 330
// Background: the pattern of image/background_pattern.glsl, with the image "over" it (premultiplied
// Porter-Duff, as ImageCompositor) when HAS_IMAGE.
#include "image/background_pattern.glsl"
#include "image/over.glsl"
#ifdef HAS_IMAGE
uniform sampler2D image;
#endif
out vec4 color;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 back = background_at(pixel);
#ifdef HAS_IMAGE
    vec4 front = texelFetch(image, pixel, 0);
    color = over(front, back);
#else
    color = back;
#endif
}
