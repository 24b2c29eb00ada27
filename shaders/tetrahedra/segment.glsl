// The ray integral across one tetrahedron, premultiplied (rgb * alpha, alpha), from the scalars at
// the segment's front and back and its length in world units:
//     vec4 segment(float s_front, float s_back, float thickness);
// One of three files defines it, chosen by the define of the processor's `integration`:
// INTEGRATION_AVERAGED (segment_averaged.glsl), INTEGRATION_PREINTEGRATED (segment_preintegrated.glsl)
// or INTEGRATION_PARTIAL (segment_partial.glsl). The others are removed by GLSL's preprocessor
// (their whole text is inside its #ifdef), so their uniforms and textures do not exist.
uniform float inverse_opacity_length;  // 1 / L (mesh.opacity_length)

// The stable opacity arithmetic they use, here outside their #ifdefs (a file is expanded once,
// where it is first included).
#include "raycasting/opacity.glsl"
#include "segment_averaged.glsl"
#include "segment_preintegrated.glsl"
#include "segment_partial.glsl"
