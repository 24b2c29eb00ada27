// Gradients of the reconstructed field in normalised intensity per world unit, from samples one
// voxel away along each axis: GRADIENT_FORWARD (f(p + h) - f(p)) / h, GRADIENT_BACKWARD
// (f(p) - f(p - h)) / h, GRADIENT_CENTRAL (f(p + h) - f(p - h)) / 2h, GRADIENT_SOBEL the 3x3x3
// Sobel operator (central difference along the axis, weights 1 2 1 across it, divided by 32 h).
// `here` is raw_sample(t), which the caller already has. Compiled only with a GRADIENT_* define.
// GRADIENT_PRECOMPUTED: central differences computed once at the voxels, interpolated by the texture
// unit (vgraph.gl.raycasting.gradient_volume): one fetch, `here` unused. With GRADIENT_HOLDS_VALUE
// the gradient texture's alpha is the volume texture's texel, so shading_texel() reads a shaded
// sample's value and gradient in one fetch.
//
// For every mode: shading_texel(t) returns the raw value at t in .a (with GRADIENT_HOLDS_VALUE, the
// encoded gradient in .rgb) and texel_gradient(t, texel) the gradient there, so a compositing loop
// that shades reads its sample once, whatever the derivatives.
#if defined(GRADIENT_PRECOMPUTED)
uniform sampler3D gradients;  // RGBA16: rgb = (32767 + g / gradient_scale * 32767) / 65535
uniform vec3 gradient_scale;  // per-axis max |g| of the volume, normalised intensity per world unit

vec3 decoded_gradient(vec4 texel) {
    return (texel.rgb * (65535.0 / 32767.0) - 1.0) * gradient_scale;
}

vec3 gradient(vec3 t, float here) {
    return decoded_gradient(textureLod(gradients, t, 0.0));  // explicit LOD: inside loops
}
#elif defined(GRADIENT_FORWARD) || defined(GRADIENT_BACKWARD) || defined(GRADIENT_CENTRAL) || defined(GRADIENT_SOBEL)
uniform vec3 voxel_step;      // one voxel in texture space: 1 / dims
uniform vec3 gradient_scale;  // intensity_scale / (h, 2h or 32h): raw differences -> per world unit

vec3 gradient(vec3 t, float here) {
    vec3 dx = vec3(voxel_step.x, 0.0, 0.0);
    vec3 dy = vec3(0.0, voxel_step.y, 0.0);
    vec3 dz = vec3(0.0, 0.0, voxel_step.z);
#if defined(GRADIENT_FORWARD)
    vec3 g = vec3(raw_sample(t + dx), raw_sample(t + dy), raw_sample(t + dz)) - here;
#elif defined(GRADIENT_BACKWARD)
    vec3 g = here - vec3(raw_sample(t - dx), raw_sample(t - dy), raw_sample(t - dz));
#elif defined(GRADIENT_CENTRAL)
    vec3 g = vec3(raw_sample(t + dx) - raw_sample(t - dx), raw_sample(t + dy) - raw_sample(t - dy),
                  raw_sample(t + dz) - raw_sample(t - dz));
#else
    vec3 g = vec3(0.0);
    for (int z = -1; z <= 1; ++z) {
        for (int y = -1; y <= 1; ++y) {
            for (int x = -1; x <= 1; ++x) {
                vec3 offset = vec3(x, y, z);
                vec3 smoothing = 2.0 - abs(offset);  // 1 off-centre, 2 on the centre line
                vec3 weight = offset * smoothing.yxx * smoothing.zzy;
                if (weight != vec3(0.0)) {
                    g += weight * raw_sample(t + offset * voxel_step);
                }
            }
        }
    }
#endif
    return g * gradient_scale;
}
#endif

#ifdef GRADIENT_HOLDS_VALUE
vec4 shading_texel(vec3 t) {
    return textureLod(gradients, t, 0.0);
}

vec3 texel_gradient(vec3 t, vec4 texel) {
    return decoded_gradient(texel);
}
#else
vec4 shading_texel(vec3 t) {
    return vec4(0.0, 0.0, 0.0, raw_sample(t));
}

#if defined(SHADING_BLINN_PHONG)
vec3 texel_gradient(vec3 t, vec4 texel) {
    return gradient(t, texel.a);
}
#endif
#endif
