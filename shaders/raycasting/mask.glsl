// The Mask component (vgraph.gl.raycasting.mask; the model: vgraph.masking). With MASK, a sample's
// mask weight: the kept indicator of the mask (R8: 1 kept, 0 hidden; smoothed, in between) at ray
// position t (texture coordinates of the volume), mapped into the mask's own texture space by
// texture_to_mask (texture -> world -> mask texture; the identity for a mask on the volume's grid).
// MASK_HARD: the mask voxel whose cell holds the point (texelFetch, no filtering); else trilinear.
// Outside the mask's grid the value is 0: weight mask_outside.
#ifdef MASK
uniform sampler3D mask;
uniform mat4 texture_to_mask;
uniform float mask_outside;
#ifdef MASK_HARD
uniform ivec3 mask_dims;
#endif

float mask_weight(vec3 t) {
    vec3 m = (texture_to_mask * vec4(t, 1.0)).xyz;
    if (any(lessThan(m, vec3(0.0))) || any(greaterThanEqual(m, vec3(1.0)))) {
        return mask_outside;
    }
#ifdef MASK_HARD
    ivec3 voxel = min(ivec3(floor(m * vec3(mask_dims))), mask_dims - 1);
    return texelFetch(mask, voxel, 0).r;
#else
    return textureLod(mask, m, 0.0).r;  // explicit LOD: no derivatives inside loops
#endif
}
#endif
