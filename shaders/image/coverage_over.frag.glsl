#version 330
// TextOverlay: `ink` (premultiplied RGBA) with the coverage in the red channel of `coverage`
// (text and scale bar rasterised on the CPU) "over" the image, as ImageCompositor composites.
uniform sampler2D image;
uniform sampler2D coverage;
uniform vec4 ink;
out vec4 color;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 front = ink * texelFetch(coverage, pixel, 0).r;
    color = front + (1.0 - front.a) * texelFetch(image, pixel, 0);
}
