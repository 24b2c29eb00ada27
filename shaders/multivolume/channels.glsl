// The channels of the MultiVolumeRayCaster: CHANNELS (1..4) volumes sampled at one ray position
// (the define, and each channel's classification channel_classify and channel_opacity, come with
// its TransferFunctionLut: raycasting/channel_transfer_functions.glsl). Rays run in the texture
// space of the first channel over the union of the channels' boxes (EntryExitPoints fed with all
// of them: coordinates outside [0, 1] where the union leaves the first box); channel k's texture
// coordinate is t * channel_scale[k] + channel_offset[k] (texture -> world of the first channel,
// then world -> texture of channel k, combined on the CPU; the identity for channel 0 and for
// channels on its grid). Slot k holds the k-th connected channel in the sampler volume{k+1},
// whatever inport it came from.
uniform sampler3D volume1;
#if CHANNELS >= 2
uniform sampler3D volume2;
#endif
#if CHANNELS >= 3
uniform sampler3D volume3;
#endif
#if CHANNELS >= 4
uniform sampler3D volume4;
#endif
// FOR_EACH_CHANNEL(CALL) expands to CALL(0); CALL(1); ... for the CHANNELS slots: written out with
// literal indices rather than a loop, because Mesa does not unroll a loop holding this much, and
// a channel index that is not a constant makes every uniform-array read and sampler choice a
// branch (llvmpipe, one unshaded channel: 2.2x the RayCaster's time as a loop, the same written
// out).
#if CHANNELS == 1
#define FOR_EACH_CHANNEL(CALL) CALL(0)
#elif CHANNELS == 2
#define FOR_EACH_CHANNEL(CALL) CALL(0); CALL(1)
#elif CHANNELS == 3
#define FOR_EACH_CHANNEL(CALL) CALL(0); CALL(1); CALL(2)
#else
#define FOR_EACH_CHANNEL(CALL) CALL(0); CALL(1); CALL(2); CALL(3)
#endif

uniform vec3 channel_scale[CHANNELS];
uniform vec3 channel_offset[CHANNELS];
uniform vec3 channel_low[CHANNELS];        // the channel's box of voxel centres (grown like the
uniform vec3 channel_high[CHANNELS];       // rays' box) in its own texture space
uniform vec2 channel_intensity[CHANNELS];  // normalised intensity = raw * x + y

// Channel k's coordinates of ray position t; false where they lie outside the channel's box (it
// has no data there and contributes nothing, instead of its edge values smeared by clamp-to-edge).
// Channel 0 is tested too (the union rays leave its box), unless it is alone: then the rays are
// its own box and it samples exactly as the RayCaster does.
bool channel_point(int k, vec3 t, out vec3 tk) {
    tk = t * channel_scale[k] + channel_offset[k];
    return (CHANNELS == 1 && k == 0)
        || (all(greaterThanEqual(tk, channel_low[k])) && all(lessThanEqual(tk, channel_high[k])));
}

// Trilinear (the textures are bound with a linear sampler); explicit LOD: no derivatives in loops.
float channel_raw(int k, vec3 tk) {
#if CHANNELS >= 2
    if (k == 1) return textureLod(volume2, tk, 0.0).r;
#endif
#if CHANNELS >= 3
    if (k == 2) return textureLod(volume3, tk, 0.0).r;
#endif
#if CHANNELS >= 4
    if (k == 3) return textureLod(volume4, tk, 0.0).r;
#endif
    return textureLod(volume1, tk, 0.0).r;
}

float channel_value(int k, vec3 tk) {
    return channel_raw(k, tk) * channel_intensity[k].x + channel_intensity[k].y;
}

#ifdef SHADING_BLINN_PHONG
uniform vec3 channel_voxel_step[CHANNELS];       // one voxel of the channel in its texture space
uniform vec3 channel_gradient_scale[CHANNELS];   // raw differences -> gradient (below)

// Central differences one voxel of channel k away along each of its axes (the RayCaster's
// `central` derivatives). The scale is intensity_scale / (2 h) per world unit, times
// min(spacing_k) / min(spacing of channel 0): shading.glsl leaves a gradient unshaded below
// 1e-6 / min(spacing of channel 0), which makes that test |g| * min(spacing_k) <= 1e-6, the
// channel's own (the direction does not change).
vec3 channel_gradient(int k, vec3 tk) {
    vec3 h = channel_voxel_step[k];
    vec3 g = vec3(channel_raw(k, tk + vec3(h.x, 0.0, 0.0)) - channel_raw(k, tk - vec3(h.x, 0.0, 0.0)),
                  channel_raw(k, tk + vec3(0.0, h.y, 0.0)) - channel_raw(k, tk - vec3(0.0, h.y, 0.0)),
                  channel_raw(k, tk + vec3(0.0, 0.0, h.z)) - channel_raw(k, tk - vec3(0.0, 0.0, h.z)));
    return g * channel_gradient_scale[k];
}
#endif
