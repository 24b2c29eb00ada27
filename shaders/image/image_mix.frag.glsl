#version 330
// ImageMix: two premultiplied images of one size, per pixel, by `factor` f:
// MODE_MIX (1 - f) a + f b; MODE_ADD a + f b; MODE_MULTIPLY a mix(1, b, f) (channel by channel);
// MODE_NEARER the pixel of the image whose depth (red channel of depth_a / depth_b: window depth,
// smaller is nearer) is smaller, a on a tie.
uniform sampler2D a;
uniform sampler2D b;
#ifdef MODE_NEARER
uniform sampler2D depth_a;
uniform sampler2D depth_b;
#endif
uniform float factor;
out vec4 color;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 first = texelFetch(a, pixel, 0);
    vec4 second = texelFetch(b, pixel, 0);
#if defined(MODE_ADD)
    color = first + factor * second;
#elif defined(MODE_MULTIPLY)
    color = first * mix(vec4(1.0), second, factor);
#elif defined(MODE_NEARER)
    color = texelFetch(depth_b, pixel, 0).r < texelFetch(depth_a, pixel, 0).r ? second : first;
#else
    color = mix(first, second, factor);
#endif
}
