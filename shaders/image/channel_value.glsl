// One value of a texel, chosen by define: CHANNEL_RED, _GREEN, _BLUE, _ALPHA, else the luminance
// of the stored (premultiplied) colour. Needs image/luminance.glsl.
float channel_value(vec4 texel) {
#if defined(CHANNEL_RED)
    return texel.r;
#elif defined(CHANNEL_GREEN)
    return texel.g;
#elif defined(CHANNEL_BLUE)
    return texel.b;
#elif defined(CHANNEL_ALPHA)
    return texel.a;
#else
    return luminance(texel.rgb);
#endif
}
