// INTEGRATION_PREINTEGRATED (Roettger et al. 2000, Kraus et al. 2004): the table of
// vgraph.gl.tetrahedra.preintegration: a = L * mean tau over [s_front, s_back], alpha =
// 1 - exp(-a l / L), rgb = (C / alpha) at (s_front, s_back, alpha).
#ifdef INTEGRATION_PREINTEGRATED
uniform sampler3D preintegrated;     // rgb at (s_front, s_back, alpha)
uniform sampler2D mean_extinction;  // its mean extinction (L * mean tau) at (s_front, s_back)

vec4 segment(float s_front, float s_back, float thickness) {
    float length_in_l = thickness * inverse_opacity_length;
    const float n = float(TABLE_SIZE), t = float(ALPHA_SLICES);
    vec2 st = clamp(vec2(s_front, s_back), 0.0, 1.0) * ((n - 1.0) / n) + 0.5 / n;
    float mean_depth = textureLod(mean_extinction, st, 0.0).r;
    float alpha = opacity_of_depth(mean_depth * length_in_l);  // 1 - exp(-depth), raycasting/opacity.glsl
    vec3 rgb = textureLod(preintegrated, vec3(st, alpha * ((t - 1.0) / t) + 0.5 / t), 0.0).rgb;
    return vec4(rgb * alpha, alpha);
}
#endif
