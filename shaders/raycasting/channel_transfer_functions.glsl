// Classification of CHANNELS channels (1..4), each by its own transfer function
// (TransferFunctionLut(channels=n), which defines CHANNELS): slot k (0-based) holds the k-th
// connected channel's 4096-entry LUT in transfer_function{k+1}, whatever inport it came from. The
// LUTs are read as raycasting/transfer_function.glsl reads its one: entry i at (i + 0.5) / 4096,
// linear filtering, intensities outside [0, 1] clamped to the end entries.
#include "raycasting/opacity.glsl"

uniform sampler2D transfer_function1;
#if CHANNELS >= 2
uniform sampler2D transfer_function2;
#endif
#if CHANNELS >= 3
uniform sampler2D transfer_function3;
#endif
#if CHANNELS >= 4
uniform sampler2D transfer_function4;
#endif
uniform float opacity_exponent;              // FrontToBack: step / min(spacing of all channels)
uniform float opacity_reference[CHANNELS];   // min(spacing of all channels) / min(spacing of channel k)

vec4 lut_lookup(sampler2D lut, float value) {
    return textureLod(lut, vec2(value * (4095.0 / 4096.0) + 0.5 / 4096.0, 0.5), 0.0);
}

// Channel k's TF colour and opacity at normalised intensity `value`. The slot is a literal at
// each call (the processor's FOR_EACH_CHANNEL), so the branches fold away.
vec4 channel_classify(int k, float value) {
#if CHANNELS >= 2
    if (k == 1) return lut_lookup(transfer_function2, value);
#endif
#if CHANNELS >= 3
    if (k == 2) return lut_lookup(transfer_function3, value);
#endif
#if CHANNELS >= 4
    if (k == 3) return lut_lookup(transfer_function4, value);
#endif
    return lut_lookup(transfer_function1, value);
}

// Opacity correction per channel (raycasting/transfer_function.glsl's rule with the channel's own
// reference step): a TF's alpha is per sample at the rate 1 of its channel, so a step gets
// 1 - (1 - a)^(step / min(spacing of the channel)). Always applied, not only under
// OPACITY_CORRECTION: at sampling rate 1 a channel coarser than the finest still needs it. An
// exponent of 1 (the finest channel at sampling rate 1) leaves alpha as it is, exactly. Below an
// opacity of 1/64 the stable form of raycasting/opacity.glsl.
float channel_opacity(int k, float alpha) {
    float exponent = opacity_exponent * opacity_reference[k];
    return (alpha >= 1.0 || exponent == 1.0) ? alpha : corrected_alpha(alpha, exponent);  // opacity.glsl
}
