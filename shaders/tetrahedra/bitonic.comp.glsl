#version 430
// The visibility sort on the GL side, step 2: one pass (k, j) of a bitonic sorting network over
// (key, value) pairs, keys descending (farthest first). The count is a power of two.
layout(local_size_x = 256) in;
layout(std430, binding = 2) buffer Keys { float keys[]; };
layout(std430, binding = 3) buffer Values { uint values[]; };
uniform uint k;  // the size of the sequences being merged
uniform uint j;  // the distance of the compared pairs

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint l = i ^ j;
    if (l <= i || l >= uint(keys.length())) return;
    bool descending = (i & k) == 0u;
    float a = keys[i], b = keys[l];
    if (descending ? a < b : a > b) {
        keys[i] = b;
        keys[l] = a;
        uint v = values[i];
        values[i] = values[l];
        values[l] = v;
    }
}
