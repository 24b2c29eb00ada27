#version 330
// Test and benchmark harness for tricubic.glsl (vgraph.gl.tricubic.evaluate_gl): one point per
// pixel. Pixel (x, y) of the target reads point x + y * width from the RGBA32F texture `points`
// (xyz = voxel coordinates) and writes the reconstruction there, derivatives per world unit:
//   out 0: (value, df/dx, df/dy, df/dz)           (gradient only with PROBE_DERIVATIVES >= 1)
//   out 1, 2, 3: the Hessian's columns x, y, z, (d/dx, d/dy, d/dz of f_x, f_y, f_z; w = 0)
//   (only with PROBE_DERIVATIVES 2; all nine entries, so that the tests see its symmetry)
// Defines: PROBE_DERIVATIVES 0, 1 or 2; TRICUBIC_FAST selects the variant (tricubic.glsl);
// PROBE_TEXTURE_SPACE goes through the texture-coordinate entry points instead of the voxel ones
// (the way a ray caster calls them), adding the float32 round trip u -> (u + 0.5) / n -> u.
#include "tricubic.glsl"

#ifndef PROBE_DERIVATIVES
#define PROBE_DERIVATIVES 0
#endif

uniform sampler3D coefficients;
uniform sampler2D points;
uniform vec3 inv_spacing;  // 1 / spacing (x, y, z)

layout(location = 0) out vec4 value_gradient;
#if PROBE_DERIVATIVES >= 2
layout(location = 1) out vec4 hessian_x;
layout(location = 2) out vec4 hessian_y;
layout(location = 3) out vec4 hessian_z;
#endif

void main() {
    vec3 p = texelFetch(points, ivec2(gl_FragCoord.xy), 0).xyz;
    float value;
    vec3 gradient = vec3(0.0);
#ifdef PROBE_TEXTURE_SPACE
    p = (p + 0.5) / vec3(textureSize(coefficients, 0));
#if PROBE_DERIVATIVES >= 2
    mat3 hessian;
    tricubic_jet(coefficients, p, value, gradient, hessian);
#elif PROBE_DERIVATIVES == 1
    tricubic_value_gradient(coefficients, p, value, gradient);
#else
    value = tricubic_value(coefficients, p);
#endif
#else  // voxel coordinates
#if PROBE_DERIVATIVES >= 2
    mat3 hessian;
    tricubic_jet_voxel(coefficients, p, value, gradient, hessian);
#elif PROBE_DERIVATIVES == 1
    tricubic_value_gradient_voxel(coefficients, p, value, gradient);
#else
    value = tricubic_value_voxel(coefficients, p);
#endif
#endif
#if PROBE_DERIVATIVES >= 2
    tricubic_world_derivatives(inv_spacing, gradient, hessian);
    hessian_x = vec4(hessian[0], 0.0);
    hessian_y = vec4(hessian[1], 0.0);
    hessian_z = vec4(hessian[2], 0.0);
#elif PROBE_DERIVATIVES == 1
    gradient = tricubic_world_gradient(inv_spacing, gradient);
#endif
    value_gradient = vec4(value, gradient);
}
