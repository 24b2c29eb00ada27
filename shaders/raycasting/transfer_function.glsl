// Classification by the 1D transfer function (Inacio 2009 ch. 4.2.1): a 4096-entry RGBA32F LUT with
// linear filtering. Entry i (intensity i / 4095) sits at texture coordinate (i + 0.5) / 4096;
// clamp-to-edge clamps intensities outside [0, 1] to the end entries.
#include "raycasting/opacity.glsl"

uniform sampler2D transfer_function;
uniform float opacity_exponent;  // step / min(spacing) = 1 / sampling_rate

vec4 classify(float intensity) {
    return textureLod(transfer_function,
                      vec2(intensity * (4095.0 / 4096.0) + 0.5 / 4096.0, 0.5), 0.0);
}

// Opacity correction (OPACITY_CORRECTION, defined when the sampling rate is not 1): the TF's alpha
// is per sample at sampling rate 1; a step of another length gets 1 - (1 - a)^(step / min spacing),
// so brightness does not depend on the sampling rate; below an opacity of 1/64 in the stable form
// -expm1(x log1p(-a)) that keeps small opacities (raycasting/opacity.glsl).
float corrected_opacity(float alpha) {
#ifdef OPACITY_CORRECTION
    return alpha >= 1.0 ? 1.0 : corrected_alpha(alpha, opacity_exponent);  // raycasting/opacity.glsl
#else
    return alpha;
#endif
}
