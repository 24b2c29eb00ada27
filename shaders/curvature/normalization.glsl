// Curvature -> [0, 1] for the colour map (Cabral 2010 sec. 5.3), zero curvature at 0.5:
//   NORMALIZATION_LINEAR       k >= 0: 0.5 + 0.5 k / kmax     k < 0: 0.5 - 0.5 k / kmin
//   NORMALIZATION_EXPONENTIAL  k >= 0: 1 - exp(-k t) / 2      k < 0: exp(k t) / 2
// with kmax = max(max k, 0) and kmin = min(min k, 0) over the image (range = (kmin, kmax), from
// the GPU reduction) and t = `attenuation` (world units). CURVATURE_CURVEDNESS (never negative)
// uses the whole map: k / kmax or 1 - exp(-k t); CURVATURE_SHAPE_INDEX (dimensionless, [-1, 1])
// maps to (k + 1) / 2 under either normalisation.
// The colour map is a 256-entry LUT texture with linear filtering (entry i at value i / 255).
uniform float attenuation;
uniform sampler2D colormap;

float normalized_curvature(float k, vec2 range) {
#if defined(CURVATURE_SHAPE_INDEX)
    return clamp(0.5 * (k + 1.0), 0.0, 1.0);
#elif defined(NORMALIZATION_LINEAR)
    float kmin = range.x, kmax = range.y;
#ifdef CURVATURE_CURVEDNESS
    return kmax > 0.0 ? clamp(k / kmax, 0.0, 1.0) : 0.0;
#else
    if (k >= 0.0) {
        return kmax > 0.0 ? clamp(0.5 + 0.5 * k / kmax, 0.5, 1.0) : 0.5;
    }
    return kmin < 0.0 ? clamp(0.5 - 0.5 * k / kmin, 0.0, 0.5) : 0.5;
#endif
#else  // NORMALIZATION_EXPONENTIAL
#ifdef CURVATURE_CURVEDNESS
    return 1.0 - exp(-max(k, 0.0) * attenuation);
#else
    return k >= 0.0 ? 1.0 - 0.5 * exp(-k * attenuation) : 0.5 * exp(k * attenuation);
#endif
#endif
}

vec3 colormap_color(float value) {
    return textureLod(colormap, vec2(value * (255.0 / 256.0) + 0.5 / 256.0, 0.5), 0.0).rgb;
}
