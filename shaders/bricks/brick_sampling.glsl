// Reconstruction inside one brick (BrickedRayCaster): the brick's texture holds its voxels and a
// halo of 2 (vgraph.bricks.cache), so trilinear filtering and the gradients of a sample the brick
// owns read the same voxels as the whole volume's texture would. raw_sample() takes the sample's
// coordinate in the level-0 volume's texture space (the global lattice of ray.glsl) and maps it
// into the brick: b = t * brick_scale + brick_offset (computed in float64 on the CPU per brick).
// Same names as raycasting/volume_sampling.glsl, so gradients.glsl works unchanged.
uniform sampler3D volume;        // this brick's texture
uniform vec3 brick_scale;
uniform vec3 brick_offset;
uniform float intensity_scale;   // normalised intensity = raw * scale + offset
uniform float intensity_offset;

float raw_sample(vec3 t) {
    return textureLod(volume, t * brick_scale + brick_offset, 0.0).r;  // explicit LOD: in loops
}

float intensity(vec3 t) {
    return raw_sample(t) * intensity_scale + intensity_offset;
}
