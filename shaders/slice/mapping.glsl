// A normalised intensity -> RGBA (not premultiplied), by the mapping the define chooses:
//   (default: window)  grey = (intensity - window_low) / window_width, clamped to [0, 1], opaque;
//                      the SliceViewer turns its window (centre, width in data values) into
//                      these normalised numbers
//   MAPPING_TF         the transfer function's colour and opacity (its 4096-entry LUT)
#include "raycasting/transfer_function.glsl"

uniform float window_low;    // normalised intensity at the window's lower end
uniform float window_width;  // normalised intensities the window spans (> 0)

vec4 mapped(float intensity) {
#ifdef MAPPING_TF
    return classify(intensity);
#else
    float grey = clamp((intensity - window_low) / window_width, 0.0, 1.0);
    return vec4(vec3(grey), 1.0);
#endif
}
