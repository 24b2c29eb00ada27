// Tricubic B-spline reconstruction from a coefficient texture (CubicSplineProcessor output):
// one interface, two implementations chosen at compile time.
//
//   default          the direct 64-fetch sum (tricubic_direct.glsl): texelFetch, exact weights
//   TRICUBIC_FAST    Sigg & Hadwiger's trilinear-fetch form (tricubic_fast.glsl): 8 fetches for
//                    the value, 32 with the gradient, 92 with the Hessian; needs a sampler with
//                    LINEAR filtering and inherits the texture unit's weight precision
//
// Entry points (coeffs: the R32F coefficient texture; values in the coefficients' stored units):
//   float tricubic_value(coeffs, p_texture)
//   void  tricubic_value_gradient(coeffs, p_texture, out value, out gradient)
//   void  tricubic_jet(coeffs, p_texture, out value, out gradient, out hessian)
// p_texture is a texture coordinate (voxel i at (i + 0.5) / n); derivatives are per voxel
// (d/du, u = p_texture * n - 0.5). tricubic_world_derivatives() turns them into per world unit.
// The *_voxel forms take the voxel coordinate u directly (no float32 round trip through [0, 1]).
// Both variants mirror the coefficients at the grid boundary like numerics.bspline.evaluate.
#include "bspline_weights.glsl"
#include "tricubic_direct.glsl"
#include "tricubic_fast.glsl"

// Voxel coordinate of a texture coordinate: u = t * n - 0.5.
vec3 tricubic_voxel_coordinate(sampler3D coeffs, vec3 p_texture) {
    return p_texture * vec3(textureSize(coeffs, 0)) - 0.5;
}

float tricubic_value_voxel(sampler3D coeffs, vec3 p_voxel) {
#ifdef TRICUBIC_FAST
    return tricubic_fast_value_voxel(coeffs, p_voxel);
#else
    return tricubic_direct_value_voxel(coeffs, p_voxel);
#endif
}

void tricubic_value_gradient_voxel(sampler3D coeffs, vec3 p_voxel, out float value,
                                   out vec3 gradient) {
#ifdef TRICUBIC_FAST
    tricubic_fast_gradient_voxel(coeffs, p_voxel, value, gradient);
#else
    tricubic_direct_gradient_voxel(coeffs, p_voxel, value, gradient);
#endif
}

void tricubic_jet_voxel(sampler3D coeffs, vec3 p_voxel, out float value, out vec3 gradient,
                        out mat3 hessian) {
#ifdef TRICUBIC_FAST
    tricubic_fast_jet_voxel(coeffs, p_voxel, value, gradient, hessian);
#else
    tricubic_direct_jet_voxel(coeffs, p_voxel, value, gradient, hessian);
#endif
}

float tricubic_value(sampler3D coeffs, vec3 p_texture) {
    return tricubic_value_voxel(coeffs, tricubic_voxel_coordinate(coeffs, p_texture));
}

void tricubic_value_gradient(sampler3D coeffs, vec3 p_texture, out float value, out vec3 gradient) {
    tricubic_value_gradient_voxel(coeffs, tricubic_voxel_coordinate(coeffs, p_texture), value,
                                  gradient);
}

void tricubic_jet(sampler3D coeffs, vec3 p_texture, out float value, out vec3 gradient,
                  out mat3 hessian) {
    tricubic_jet_voxel(coeffs, tricubic_voxel_coordinate(coeffs, p_texture), value, gradient,
                       hessian);
}

// Per-voxel derivatives -> per world unit: d/dx = (d/du) / spacing_x, d2/dx_a dx_b divided by
// spacing_a * spacing_b. inv_spacing = 1 / spacing (x, y, z).
void tricubic_world_derivatives(vec3 inv_spacing, inout vec3 gradient, inout mat3 hessian) {
    gradient *= inv_spacing;
    hessian = matrixCompMult(hessian, outerProduct(inv_spacing, inv_spacing));
}

vec3 tricubic_world_gradient(vec3 inv_spacing, vec3 gradient) {
    return gradient * inv_spacing;
}
