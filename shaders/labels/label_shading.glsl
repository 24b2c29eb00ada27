// Shading of a label sample (SHADING_BLINN_PHONG, raycasting/shading.glsl): the normal is the
// gradient of the winning label's weight sum (Label.slope per voxel step, divided by the spacing:
// per world unit), which the majority rule has already, so shading costs no extra fetch.
uniform vec3 voxel_spacing;  // world units per voxel step (x, y, z)

vec3 label_shade(vec3 rgb, Label label, Ray ray) {
#ifdef SHADING_BLINN_PHONG
    return shade(rgb, label.slope / voxel_spacing, -ray.direction);
#else
    return rgb;
#endif
}
