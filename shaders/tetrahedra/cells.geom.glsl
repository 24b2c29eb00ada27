#version 330
// Cell projection, geometry stage: one grid cell becomes the screen rectangle around its eight
// projected corners (two triangles); the fragment stage intersects each pixel's ray with the cell
// and its five tetrahedra and drops the pixels whose ray misses it (cells.frag.glsl). On llvmpipe
// the rectangle beats the exact silhouette (a hexagon of four triangles): per triangle costs more
// than the pixels it adds (docs/explanations/tetrahedra-renderer.md, Performance).
//
// What the fragment stage needs, flat: the cell's unit coordinates as an affine map of world
// coordinates, mirrored in x for odd cells (whose corner tetrahedra are then those of an even cell),
// and the scalar's plane in each of the five tetrahedra.
layout(points) in;
layout(triangle_strip, max_vertices = 4) out;

in vec4 v_cell[];
in vec4 v_scalars_low[];
in vec4 v_scalars_high[];
flat out vec4 unit_origin;  // p = (x - unit_origin.xyz) * (unit_origin.w / spacing.x, 1 / spacing.y, 1 / spacing.z)
flat out vec4 planes[5];    // (gradient, value at p = 0): corners 000, 110, 101, 011, then the central one

uniform mat4 view_projection;
uniform vec3 spacing;  // the cell's size along x, y, z (world units)

vec4 cell_origin;
vec4 cell_planes[5];

void corner(vec2 ndc) {
    unit_origin = cell_origin;
    for (int k = 0; k < 5; ++k) planes[k] = cell_planes[k];
    gl_Position = vec4(ndc, 0.0, 1.0);  // z = 0: near and far do not clip
    EmitVertex();
}

// The scalar's plane in each tetrahedron of an even cell: the interpolation of its four corners,
// s_c + sum over the axes of (s at the neighbour along the axis - s_c) |p - c|.
void scalar_planes(vec4 low, vec4 high) {
    float s0 = low.x, s1 = low.y, s2 = low.z, s3 = low.w, s4 = high.x, s5 = high.y, s6 = high.z,
          s7 = high.w;
    cell_planes[0] = vec4(s1 - s0, s2 - s0, s4 - s0, s0);             // corner 000: 0, 1, 2, 4
    cell_planes[1] = vec4(s3 - s2, s3 - s1, s7 - s3, s1 + s2 - s3);   // corner 110: 3, 2, 1, 7
    cell_planes[2] = vec4(s5 - s4, s7 - s5, s5 - s1, s1 + s4 - s5);   // corner 101: 5, 4, 7, 1
    cell_planes[3] = vec4(s7 - s6, s6 - s4, s6 - s2, s2 + s4 - s6);   // corner 011: 6, 7, 4, 2
    float centre = 0.5 * (s1 + s2 + s4 - s7);                         // central: 1, 2, 4, 7
    cell_planes[4] = vec4(s1 - centre, s2 - centre, s4 - centre, centre);
}

void main() {
    vec3 low = v_cell[0].xyz;
    vec4 origin_clip = view_projection * vec4(low, 1.0);
    vec4 step_x = view_projection * vec4(spacing.x, 0.0, 0.0, 0.0);
    vec4 step_y = view_projection * vec4(0.0, spacing.y, 0.0, 0.0);
    vec4 step_z = view_projection * vec4(0.0, 0.0, spacing.z, 0.0);
    vec2 lo = vec2(1e30), hi = vec2(-1e30);
    for (int c = 0; c < 8; ++c) {
        vec4 clip = origin_clip + float(c & 1) * step_x + float((c >> 1) & 1) * step_y
                    + float((c >> 2) & 1) * step_z;
        if (clip.w <= 0.0) return;  // a corner behind the eye: the cell is not drawn
        lo = min(lo, clip.xy / clip.w);
        hi = max(hi, clip.xy / clip.w);
    }
    bool odd = v_cell[0].w > 0.5;
    cell_origin = odd ? vec4(low.x + spacing.x, low.yz, -1.0) : vec4(low, 1.0);
    scalar_planes(odd ? v_scalars_low[0].yxwz : v_scalars_low[0],
                  odd ? v_scalars_high[0].yxwz : v_scalars_high[0]);
    corner(lo);
    corner(vec2(hi.x, lo.y));
    corner(vec2(lo.x, hi.y));
    corner(hi);
    EndPrimitive();
}
