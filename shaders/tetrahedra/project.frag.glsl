#version 330
// Projected tetrahedra, fragment stage: the ray integral across one tetrahedron from the front and
// back points of the pixel's ray (project.geom.glsl), premultiplied for "over" blending back to
// front (glBlendFunc(ONE, ONE_MINUS_SRC_ALPHA)).
//
// INTEGRATION_AVERAGED (Shirley & Tuchman 1990, Monsalve 2016): the TF at the mean scalar
// (s_front + s_back) / 2 gives colour c and opacity a; alpha = 1 - exp(-tau l) = 1 - (1 - a)^(l / L)
// with tau = -ln(1 - a) / L (the opacity of a sample at rate 1 over the length L).
// INTEGRATION_PREINTEGRATED (Roettger et al. 2000, Kraus et al. 2004): the table of
// vgraph.gl.tetrahedra.preintegration: a = L * mean tau over [s_front, s_back], alpha =
// 1 - exp(-a l / L), rgb = (C / alpha) at (s_front, s_back, alpha).
//
// Second output (the depth image): (window depth of the front point, its distance from the ray's
// start on the near plane, 0, 1) where alpha > 0, else 0, which the blending leaves as it was: the
// last tetrahedron with opacity drawn, the nearest in the visibility order, wins.
#include "raycasting/transfer_function.glsl"

noperspective in vec4 front_h;
noperspective in vec4 back_h;
noperspective in vec2 scalar_h;
flat in vec3 limits;  // (depth extent of the tetrahedron along view_forward, scalar min, max)
uniform vec3 view_forward;

uniform float inverse_opacity_length;  // 1 / L (mesh.opacity_length)
uniform mat4 view_projection;
uniform vec2 viewport_size;
uniform vec3 near_centre;  // the pixel centre (ndc_x, ndc_y) is at near_centre + ndc_x near_right
uniform vec3 near_right;   // + ndc_y near_up on the near plane (where Camera.rays start)
uniform vec3 near_up;
#ifdef INTEGRATION_PREINTEGRATED
uniform sampler3D preintegrated;
#endif

layout(location = 0) out vec4 color;
layout(location = 1) out vec4 depth;

vec4 segment(float s_front, float s_back, float thickness) {
    float length_in_l = thickness * inverse_opacity_length;
#ifdef INTEGRATION_PREINTEGRATED
    const float n = float(TABLE_SIZE), t = float(ALPHA_SLICES);
    vec2 st = clamp(vec2(s_front, s_back), 0.0, 1.0) * ((n - 1.0) / n) + 0.5 / n;
    float mean_depth = textureLod(preintegrated, vec3(st, 0.5 / t), 0.0).a;
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

void main() {
    vec3 x_front = front_h.xyz / front_h.w;
    vec3 x_back = back_h.xyz / back_h.w;
    float s_front = clamp(scalar_h.x / front_h.w, limits.y, limits.z);
    float s_back = clamp(scalar_h.y / back_h.w, limits.y, limits.z);
    // A segment inside the tetrahedron spans at most its depth extent along the view direction;
    // beyond it (a ray grazing a face seen almost edge-on), shorten it to that.
    float thickness = distance(x_front, x_back);
    float across = abs(dot(x_back - x_front, view_forward));
    if (across > limits.x) thickness *= limits.x / across;
    color = segment(s_front, s_back, thickness);
    if (color.a > 0.0) {
        vec4 clip = view_projection * vec4(x_front, 1.0);
        vec2 ndc = gl_FragCoord.xy / viewport_size * 2.0 - 1.0;
        vec3 origin = near_centre + ndc.x * near_right + ndc.y * near_up;
        depth = vec4(clip.z / clip.w * 0.5 + 0.5, distance(x_front, origin), 0.0, 1.0);
    } else {
        depth = vec4(0.0);
    }
}
