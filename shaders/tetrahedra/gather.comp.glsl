#version 430
// The visibility sort on the GL side, step 3: the tetrahedra in sorted order, written straight into
// the index buffer the draw reads (nothing goes back to the CPU).
layout(local_size_x = 256) in;
layout(std430, binding = 1) readonly buffer Tets { ivec4 tets[]; };
layout(std430, binding = 3) readonly buffer Values { uint values[]; };
layout(std430, binding = 4) writeonly buffer Sorted { ivec4 sorted[]; };
uniform uint count;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    sorted[i] = tets[values[i]];
}
