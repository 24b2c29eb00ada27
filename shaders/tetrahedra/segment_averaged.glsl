// INTEGRATION_AVERAGED (Shirley & Tuchman 1990, Monsalve 2016): the TF at the mean scalar
// (s_front + s_back) / 2 gives colour c and opacity a; alpha = 1 - exp(-tau l) = 1 - (1 - a)^(l / L)
// with tau = -ln(1 - a) / L (the opacity of a sample at rate 1 over the length L).
#ifdef INTEGRATION_AVERAGED
#include "raycasting/transfer_function.glsl"

vec4 segment(float s_front, float s_back, float thickness) {
    float length_in_l = thickness * inverse_opacity_length;
    vec4 c = classify(0.5 * (s_front + s_back));
    float alpha = c.a >= 1.0 ? (thickness > 0.0 ? 1.0 : 0.0)
                             : opacity_over(c.a, length_in_l);  // raycasting/opacity.glsl
    return vec4(c.rgb * alpha, alpha);
}
#endif
