// INTEGRATION_PARTIAL (Moreland & Angel 2004; vgraph.gl.tetrahedra.partial_preintegration): the TF
// as knots with colour and L * tau linear between them (knot_positions, knot_values), and the
// TF-independent table phi of Phi(D_f, D_b) = 1 - Psi, a piece's mean opacity, at
// gamma = D / (1 + D). The segment is split where its scalar crosses a knot; each piece, front to
// back, has optical depth D = (D_f + D_b) / 2, opacity alpha = 1 - exp(-D) and colour
// C = c_f Phi + c_b (alpha - Phi), composited under the depth of the pieces in front of it. Small
// depths stay exact in relative terms: Phi from its series below PHI_SERIES_DEPTH, alpha and the
// segment's opacity from opacity_of_depth (raycasting/opacity.glsl).
#ifdef INTEGRATION_PARTIAL
#include "raycasting/opacity.glsl"
uniform sampler2D knot_positions;  // R32F (knot_count, 1), ascending
uniform sampler2D knot_values;     // RGBA32F (knot_count, 1): rgb, L * tau
uniform sampler2D phi;             // R32F (PSI_SIZE, PSI_SIZE), linear filtering
uniform int knot_count;

float knot_position(int i) { return texelFetch(knot_positions, ivec2(i, 0), 0).r; }
vec4 knot_value(int i) { return texelFetch(knot_values, ivec2(i, 0), 0); }

// The piece i (knots i and i + 1) holding s: the last knot at or below s, at most knot_count - 2.
int piece_of(float s) {
    int low = 0, high = knot_count - 2;
    while (low < high) {
        int middle = (low + high + 1) / 2;
        if (knot_position(middle) <= s) low = middle; else high = middle - 1;
    }
    return low;
}

vec4 value_on_piece(int i, float s) {
    float lo = knot_position(i), hi = knot_position(i + 1);
    float f = hi > lo ? clamp((s - lo) / (hi - lo), 0.0, 1.0) : 0.0;
    return mix(knot_value(i), knot_value(i + 1), f);
}

float phi_of(float depth_front, float depth_back) {
    if (max(depth_front, depth_back) < PHI_SERIES_DEPTH) {  // integral of T - T^2 / 2
        float slope = depth_back - depth_front;
        return depth_front / 3.0 + depth_back / 6.0
               - 0.5 * (depth_front * depth_front / 3.0 + depth_front * slope / 4.0 + slope * slope / 20.0);
    }
    const float n = float(PSI_SIZE);
    vec2 gamma = vec2(depth_front, depth_back) / (1.0 + vec2(depth_front, depth_back));
    return textureLod(phi, gamma * ((n - 1.0) / n) + 0.5 / n, 0.0).r;
}

vec4 segment(float s_front, float s_back, float thickness) {
    float low = knot_position(0), high = knot_position(knot_count - 1);
    s_front = clamp(s_front, low, high);
    s_back = clamp(s_back, low, high);
    float length_in_l = thickness * inverse_opacity_length;
    float ds = s_back - s_front;
    int first = piece_of(s_front), last = piece_of(s_back);
    int direction = last >= first ? 1 : -1;
    vec3 color = vec3(0.0);
    float total_depth = 0.0;
    float x0 = 0.0;
    vec4 v0 = value_on_piece(first, s_front);
    for (int i = first; ; i += direction) {
        float x1;
        vec4 v1;
        if (i == last) {
            x1 = 1.0;
            v1 = value_on_piece(last, s_back);
        } else {  // leave the piece through its upper knot (rising scalar) or its lower one
            int k = direction > 0 ? i + 1 : i;
            x1 = clamp((knot_position(k) - s_front) / ds, x0, 1.0);
            v1 = knot_value(k);
        }
        float scale = (x1 - x0) * length_in_l;
        float depth_front = v0.a * scale, depth_back = v1.a * scale;
        float depth = 0.5 * (depth_front + depth_back);
        float mean_opacity = phi_of(depth_front, depth_back);
        color += exp(-total_depth) * (v0.rgb * mean_opacity + v1.rgb * (opacity_of_depth(depth) - mean_opacity));
        total_depth += depth;
        if (i == last) break;
        x0 = x1;
        v0 = v1;
    }
    return vec4(color, opacity_of_depth(total_depth));
}
#endif
