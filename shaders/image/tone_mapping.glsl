// Tone mapping of a straight colour scaled by `exposure` (x = exposure * max(c, 0)), per channel:
// TONE_REINHARD x / (1 + x) (Reinhard et al. 2002, the global operator on each channel),
// TONE_EXPOSURE 1 - exp(-x) (the photographic exposure curve), otherwise x unchanged.
uniform float exposure;

vec3 tone_mapped(vec3 straight) {
    vec3 x = exposure * max(straight, vec3(0.0));
#if defined(TONE_REINHARD)
    return x / (1.0 + x);
#elif defined(TONE_EXPOSURE)
    return 1.0 - exp(-x);
#else
    return x;
#endif
}
