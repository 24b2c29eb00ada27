// Shading of a label sample (SHADING_BLINN_PHONG, raycasting/shading.glsl): the normal is a slope
// of the majority rule's weight sums (majority.glsl: per voxel step, divided by the spacing: per
// world unit), which the rule has already computed, so shading costs no extra fetch. Composite
// shades with the winning label's slope (each label's own boundary, also inside other labels),
// first_hit with the surface slope of all shown labels together (no seam where two labels touch).
uniform vec3 voxel_spacing;  // world units per voxel step (x, y, z)

vec3 label_shade(vec3 rgb, vec3 slope, Ray ray) {
#ifdef SHADING_BLINN_PHONG
    return shade(rgb, slope / voxel_spacing, -ray.direction);
#else
    return rgb;
#endif
}
