// The CutAway component (vgraph.gl.raycasting.mask; the model: vgraph.masking). With CUTAWAY_BOX or
// CUTAWAY_SPHERE, weight 0 for samples inside the region: texture_to_region maps ray position t
// (texture coordinates of the volume) to region coordinates q (texture -> world -> region), inside
// where max |q_k| <= 1 (box) or |q| <= 1 (sphere, an ellipsoid for unequal sizes).
#if defined(CUTAWAY_BOX) || defined(CUTAWAY_SPHERE)
uniform mat4 texture_to_region;

float cutaway_weight(vec3 t) {
    vec3 q = (texture_to_region * vec4(t, 1.0)).xyz;
#ifdef CUTAWAY_BOX
    return max(max(abs(q.x), abs(q.y)), abs(q.z)) <= 1.0 ? 0.0 : 1.0;
#else
    return dot(q, q) <= 1.0 ? 0.0 : 1.0;
#endif
}
#endif
