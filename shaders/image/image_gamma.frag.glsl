#version 330
// ImageGamma: tone mapping (image/tone_mapping.glsl) then the gamma curve c^(1 / gamma) on the
// straight colour; alpha is kept and the result premultiplied by it again.
#include "image/straight_color.glsl"
#include "image/tone_mapping.glsl"
uniform sampler2D image;
uniform float gamma;
out vec4 color;

void main() {
    vec4 original = texelFetch(image, ivec2(gl_FragCoord.xy), 0);
    vec3 mapped = pow(tone_mapped(straight_color(original)), vec3(1.0 / gamma));
    color = premultiplied(mapped, original.a);
}
