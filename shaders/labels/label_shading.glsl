// Shading of a label sample (SHADING_BLINN_PHONG, raycasting/shading.glsl): the normal is
// Label.normal (majority.glsl), a slope of the weight sums the rule has already computed, per
// voxel step, divided by the spacing (per world unit): shading costs no extra fetch.
uniform vec3 voxel_spacing;  // world units per voxel step (x, y, z)

vec3 label_shade(vec3 rgb, Label label, Ray ray) {
#ifdef SHADING_BLINN_PHONG
    return shade(rgb, label.normal / voxel_spacing, -ray.direction);
#else
    return rgb;
#endif
}
