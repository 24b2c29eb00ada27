#version 330
// EdgeDetect: the Sobel magnitude of one channel, times `scale`. EDGES_ONLY: the magnitude as an
// opaque grey image (unclamped floats); otherwise the contours over the input, premultiplied:
// the edge colour with coverage clamp(magnitude * scale, 0, 1) * edge_color.a "over" the input.
// CHANNEL_ALPHA / CHANNEL_RED pick alpha or red (a depth image's window depth), else luminance.
#include "image/edge_texel.glsl"
#include "image/luminance.glsl"
uniform sampler2D image;     // what the contours are drawn over
uniform sampler2D edges_of;  // what the edges are of (the image itself when nothing else is given)
uniform float scale;
uniform vec4 edge_color;
out vec4 color;

float edge_value(vec4 texel) {
#if defined(CHANNEL_ALPHA)
    return texel.a;
#elif defined(CHANNEL_RED)
    return texel.r;
#else
    return luminance(texel.rgb);
#endif
}

#include "image/sobel.glsl"

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    float edge = sobel_magnitude(edges_of, pixel) * scale;
#ifdef EDGES_ONLY
    color = vec4(vec3(edge), 1.0);
#else
    float coverage = clamp(edge, 0.0, 1.0) * edge_color.a;
    color = vec4(edge_color.rgb * coverage, coverage) + (1.0 - coverage) * texelFetch(image, pixel, 0);
#endif
}
