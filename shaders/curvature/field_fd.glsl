// The field of the finite-difference modes (DERIVATIVES_FORWARD, _CENTRAL, _FILTERED): the
// trilinear reconstruction of voxel SAMPLES (raw_sample() of raycasting/volume_sampling.glsl) and
// its derivatives from samples one voxel apart along each axis (the CPU reference is
// vgraph.numerics.finite_differences; docs/explanations/curvature.md has the formulas):
//   forward   g_a = f(p + e_a) - f(p), H_ab = f(p + e_a + e_b) - f(p + e_a) - f(p + e_b) + f(p)
//             (forward differences of the forward differences; 10 fetches)
//   central   g_a = (f(p + e_a) - f(p - e_a)) / 2, H_aa = f(p + e_a) - 2 f(p) + f(p - e_a),
//             H_ab = (f(p + e_a + e_b) - f(p + e_a - e_b) - f(p - e_a + e_b) + f(p - e_a - e_b)) / 4
//             (19 fetches)
//   filtered  1/4 central(p) + 3/4 mean of central(p + d) over the 8 diagonal neighbours
//             d in {-1, +1}^3 voxels, for gradient and Hessian alike (Voreen's
//             calcGradientFiltered, Cabral 2010 "trilinear"; 171 fetches)
// in voxel units, then divided by the spacings and scaled to normalised intensity.
// Steps of exactly one voxel keep the fractional position inside the voxel cell, so the
// trilinear interpolation error cancels from the differences (to first order).
#if defined(DERIVATIVES_FORWARD) || defined(DERIVATIVES_CENTRAL) || defined(DERIVATIVES_FILTERED)
uniform vec3 voxel_step;   // one voxel in texture space: 1 / dims
uniform vec3 inv_spacing;  // 1 / spacing (x, y, z)

// The value the hit search marches on and refines with (raw texture units).
float march_value(vec3 t) {
    return raw_sample(t);
}

float field_value(vec3 t) {
    return raw_sample(t);
}

float sample_offset(vec3 t, vec3 offset_voxels) {
    return raw_sample(t + offset_voxels * voxel_step);
}

#ifdef DERIVATIVES_FORWARD
void voxel_derivatives(vec3 t, out vec3 g, out mat3 h) {
    float here = raw_sample(t);
    vec3 one = vec3(sample_offset(t, vec3(1, 0, 0)), sample_offset(t, vec3(0, 1, 0)),
                    sample_offset(t, vec3(0, 0, 1)));
    vec3 two = vec3(sample_offset(t, vec3(2, 0, 0)), sample_offset(t, vec3(0, 2, 0)),
                    sample_offset(t, vec3(0, 0, 2)));
    float xy = sample_offset(t, vec3(1, 1, 0)) - one.x - one.y + here;
    float xz = sample_offset(t, vec3(1, 0, 1)) - one.x - one.z + here;
    float yz = sample_offset(t, vec3(0, 1, 1)) - one.y - one.z + here;
    g = one - here;
    vec3 second = two - 2.0 * one + here;
    h = mat3(second.x, xy, xz, xy, second.y, yz, xz, yz, second.z);
}
#else
void central_voxel_derivatives(vec3 t, out vec3 g, out mat3 h) {
    float here = raw_sample(t);
    vec3 plus = vec3(sample_offset(t, vec3(1, 0, 0)), sample_offset(t, vec3(0, 1, 0)),
                     sample_offset(t, vec3(0, 0, 1)));
    vec3 minus = vec3(sample_offset(t, vec3(-1, 0, 0)), sample_offset(t, vec3(0, -1, 0)),
                      sample_offset(t, vec3(0, 0, -1)));
    float xy = 0.25 * (sample_offset(t, vec3(1, 1, 0)) - sample_offset(t, vec3(1, -1, 0))
                       - sample_offset(t, vec3(-1, 1, 0)) + sample_offset(t, vec3(-1, -1, 0)));
    float xz = 0.25 * (sample_offset(t, vec3(1, 0, 1)) - sample_offset(t, vec3(1, 0, -1))
                       - sample_offset(t, vec3(-1, 0, 1)) + sample_offset(t, vec3(-1, 0, -1)));
    float yz = 0.25 * (sample_offset(t, vec3(0, 1, 1)) - sample_offset(t, vec3(0, 1, -1))
                       - sample_offset(t, vec3(0, -1, 1)) + sample_offset(t, vec3(0, -1, -1)));
    g = 0.5 * (plus - minus);
    vec3 second = plus - 2.0 * here + minus;
    h = mat3(second.x, xy, xz, xy, second.y, yz, xz, yz, second.z);
}

#ifdef DERIVATIVES_CENTRAL
void voxel_derivatives(vec3 t, out vec3 g, out mat3 h) {
    central_voxel_derivatives(t, g, h);
}
#else  // DERIVATIVES_FILTERED
void voxel_derivatives(vec3 t, out vec3 g, out mat3 h) {
    central_voxel_derivatives(t, g, h);
    g *= 0.25;
    h *= 0.25;
    for (int corner = 0; corner < 8; ++corner) {
        vec3 d = vec3((corner & 1) != 0 ? 1.0 : -1.0, (corner & 2) != 0 ? 1.0 : -1.0,
                      (corner & 4) != 0 ? 1.0 : -1.0);
        vec3 gd;
        mat3 hd;
        central_voxel_derivatives(t + d * voxel_step, gd, hd);
        g += (0.75 / 8.0) * gd;
        h += (0.75 / 8.0) * hd;
    }
}
#endif
#endif

// Gradient (normalised intensity per world unit) and Hessian (per world unit squared) at t.
void field_derivatives(vec3 t, out vec3 g, out mat3 h) {
    voxel_derivatives(t, g, h);
    g *= inv_spacing * intensity_scale;
    h = matrixCompMult(h, outerProduct(inv_spacing, inv_spacing)) * intensity_scale;
}
#endif
