#version 330
uniform sampler2D image;
out vec4 color;

void main() {
    vec4 value = texelFetch(image, ivec2(gl_FragCoord.xy), 0);
#ifdef INVERT_ALPHA
    color = 1.0 - value;
#else
    color = vec4(1.0 - value.rgb, value.a);
#endif
}
