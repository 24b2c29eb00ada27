// The ray integral across one tetrahedron, premultiplied (rgb * alpha, alpha), from the scalars at
// the segment's front and back and its length in world units.
//
// INTEGRATION_AVERAGED (Shirley & Tuchman 1990, Monsalve 2016): the TF at the mean scalar
// (s_front + s_back) / 2 gives colour c and opacity a; alpha = 1 - exp(-tau l) = 1 - (1 - a)^(l / L)
// with tau = -ln(1 - a) / L (the opacity of a sample at rate 1 over the length L).
// INTEGRATION_PREINTEGRATED (Roettger et al. 2000, Kraus et al. 2004): the table of
// vgraph.gl.tetrahedra.preintegration: a = L * mean tau over [s_front, s_back], alpha =
// 1 - exp(-a l / L), rgb = (C / alpha) at (s_front, s_back, alpha).
#include "raycasting/transfer_function.glsl"

uniform float inverse_opacity_length;  // 1 / L (mesh.opacity_length)
#ifdef INTEGRATION_PREINTEGRATED
uniform sampler3D preintegrated;     // rgb at (s_front, s_back, alpha)
uniform sampler2D mean_extinction;  // its mean extinction (L * mean tau) at (s_front, s_back)
#endif

vec4 segment(float s_front, float s_back, float thickness) {
    float length_in_l = thickness * inverse_opacity_length;
#ifdef INTEGRATION_PREINTEGRATED
    const float n = float(TABLE_SIZE), t = float(ALPHA_SLICES);
    vec2 st = clamp(vec2(s_front, s_back), 0.0, 1.0) * ((n - 1.0) / n) + 0.5 / n;
    float mean_depth = textureLod(mean_extinction, st, 0.0).r;
    float alpha = 1.0 - exp(-mean_depth * length_in_l);
    vec3 rgb = textureLod(preintegrated, vec3(st, alpha * ((t - 1.0) / t) + 0.5 / t), 0.0).rgb;
    return vec4(rgb * alpha, alpha);
#else
    vec4 c = classify(0.5 * (s_front + s_back));
    float alpha = c.a >= 1.0 ? (thickness > 0.0 ? 1.0 : 0.0)
                             : 1.0 - exp2(length_in_l * log2(1.0 - c.a));
    return vec4(c.rgb * alpha, alpha);
#endif
}
