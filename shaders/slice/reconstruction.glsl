// The volume's normalised intensity at a voxel coordinate p, by the interpolation the define
// chooses:
//   INTERPOLATION_NEAREST  the voxel whose cell holds p (texelFetch, raycasting/volume_sampling.glsl)
//   (default: linear)      trilinear by the texture unit (the SliceViewer binds a LINEAR sampler)
//   INTERPOLATION_CUBIC    the cubic B-spline through the voxels (Cabral 2010 sec. 3.1-3.2): the
//                          `volume` texture then holds the prefiltered coefficients, evaluated by
//                          the direct 64-fetch sum (tricubic/tricubic.glsl, mirror boundary)
#include "raycasting/volume_sampling.glsl"
#include "tricubic/tricubic.glsl"

float intensity_at(vec3 p) {
#ifdef INTERPOLATION_CUBIC
    return tricubic_value_voxel(volume, p) * intensity_scale + intensity_offset;
#else
    return intensity((p + 0.5) / vec3(textureSize(volume, 0)));  // voxel i at (i + 0.5) / n
#endif
}
