#version 430
// The visibility sort on the GL side (vgraph.gl.tetrahedra.gl_sort), step 1: each tetrahedron's
// key, the depth of its centroid (orthographic: along the view direction; PERSPECTIVE: squared
// distance from the eye), and its index. Slots past the count get the lowest key, so that a sort
// farthest first leaves them at the end.
layout(local_size_x = 256) in;
layout(std430, binding = 0) readonly buffer Points { vec4 points[]; };
layout(std430, binding = 1) readonly buffer Tets { ivec4 tets[]; };
layout(std430, binding = 2) writeonly buffer Keys { float keys[]; };
layout(std430, binding = 3) writeonly buffer Values { uint values[]; };
uniform uint count;
uniform vec3 eye;
uniform vec3 view_forward;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(keys.length())) return;
    if (i >= count) {
        keys[i] = -3.0e38;
        values[i] = 0u;
        return;
    }
    ivec4 t = tets[i];
    vec3 middle = 0.25 * (points[t.x].xyz + points[t.y].xyz + points[t.z].xyz + points[t.w].xyz);
    vec3 from_eye = middle - eye;
#ifdef PERSPECTIVE
    keys[i] = dot(from_eye, from_eye);
#else
    keys[i] = dot(from_eye, view_forward);
#endif
    values[i] = i;
}
