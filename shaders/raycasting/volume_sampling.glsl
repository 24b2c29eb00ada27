// Reconstruction of the volume at texture coordinates: trilinear by the texture unit (the
// RayCaster binds a sampler with linear filtering; uint8 volumes come as an R16 copy, see
// vgraph.gl.volume_rendering) or, with INTERPOLATION_NEAREST, the nearest voxel by texelFetch.
// raw_sample() returns the texture's value; intensity() the normalised intensity.
uniform sampler3D volume;
uniform float intensity_scale;   // normalised intensity = raw * scale + offset
uniform float intensity_offset;

#ifdef INTERPOLATION_NEAREST
uniform ivec3 volume_dims;

float raw_sample(vec3 t) {
    ivec3 voxel = clamp(ivec3(floor(t * vec3(volume_dims))), ivec3(0), volume_dims - 1);
    return texelFetch(volume, voxel, 0).r;
}
#else
float raw_sample(vec3 t) {
    return textureLod(volume, t, 0.0).r;  // explicit LOD: no derivatives inside loops
}
#endif

float intensity(vec3 t) {
    return raw_sample(t) * intensity_scale + intensity_offset;
}
