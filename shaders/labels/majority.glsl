// Labels at a sample point by the majority of interpolation weights (vgraph.labels has the CPU
// reference): the 8 voxels whose centres surround the point (the point clamped into the box of
// the voxel centres, as clamp-to-edge filtering weighs) vote with their trilinear weights; each
// class (a shown label, or the background for every label that is not shown) sums the weights of
// its voxels; the largest sum wins, on a tie the smaller code, and the background (the largest code) loses every tie.
// Labels are read exactly by texelFetch from an unsigned integer texture: never interpolated as
// numbers, so labels 1 and 3 never make a 2.
uniform usampler3D labels;        // codes (vgraph.labels.LabelCodes), R16UI or R32UI
uniform sampler2D label_colors;   // per code: rgb, a = opacity (0 where the label is not shown)
uniform ivec3 volume_dims;

const uint BACKGROUND = 0xFFFFFFFFu;
const int LABEL_ROW = 256;        // label_colors holds LABEL_ROW codes per row

vec4 code_color(uint code) {
    return texelFetch(label_colors, ivec2(int(code) % LABEL_ROW, int(code) / LABEL_ROW), 0);
}

struct Label {
    uint code;      // the winning class: a code, or BACKGROUND
    float weight;   // its weight sum
    vec3 normal;    // for shading, per voxel step (x, y, z): where the 8 voxels include background,
                    // d(weight of all shown labels) / d(voxel index), the normal of their outer
                    // surface (no seam where two labels touch); else d(weight) / d(voxel index),
                    // the label's own boundary with another label
};

Label majority_label(vec3 t) {
    // Clamped into the box of the voxel centres first: a sample on a face (the entry point) must
    // not fall one float32 rounding outside it, where clamped corners change the slope.
    vec3 p = clamp(t * vec3(volume_dims) - 0.5, vec3(0.0), vec3(volume_dims - 1));
    vec3 base = clamp(floor(p), vec3(0.0), vec3(max(volume_dims - 2, ivec3(0))));
    vec3 f = p - base;
    ivec3 corner0 = ivec3(base);
    uint codes[8];
    bool one_code = true;
    for (int c = 0; c < 8; ++c) {
        ivec3 voxel = min(corner0 + ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1), volume_dims - 1);
        codes[c] = texelFetch(labels, voxel, 0).r;
        one_code = one_code && codes[c] == codes[0];
    }
    if (one_code) {  // inside a label or the background (most samples): all weight, no slope
        return Label(code_color(codes[0]).a > 0.0 ? codes[0] : BACKGROUND, 1.0, vec3(0.0));
    }
    uint votes[8];
    float weights[8];
    vec3 slopes[8];
    vec3 surface = vec3(0.0);
    bool background = false;
    for (int c = 0; c < 8; ++c) {
        ivec3 offset = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        uint code = codes[c];
        votes[c] = code_color(code).a > 0.0 ? code : BACKGROUND;
        vec3 axis = mix(1.0 - f, f, vec3(offset));  // per-axis weights of this corner
        weights[c] = axis.x * axis.y * axis.z;
        slopes[c] = (vec3(offset) * 2.0 - 1.0) * vec3(axis.y * axis.z, axis.x * axis.z, axis.x * axis.y);
        surface += votes[c] != BACKGROUND ? slopes[c] : vec3(0.0);
        background = background || votes[c] == BACKGROUND;
    }
    Label best = Label(BACKGROUND, -1.0, vec3(0.0));
    for (int c = 0; c < 8; ++c) {
        float sum = 0.0;
        vec3 slope = vec3(0.0);
        for (int d = 0; d < 8; ++d) {
            if (votes[d] == votes[c]) {
                sum += weights[d];
                slope += slopes[d];
            }
        }
        if (sum > best.weight || (sum == best.weight && votes[c] < best.code)) {
            best = Label(votes[c], sum, slope);
        }
    }
    if (background) {
        best.normal = surface;
    }
    return best;
}
