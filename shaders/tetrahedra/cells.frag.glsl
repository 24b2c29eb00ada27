#version 330
// Cell projection, fragment stage: the pixel's ray through one grid cell and its five tetrahedra
// (vgraph.tetrahedralize: four corner tetrahedra cut off alternate corners, and the central one),
// integrated piece by piece and composited front to back here, so the cell is one premultiplied
// colour for "over" blending (glBlendFunc(ONE, ONE_MINUS_SRC_ALPHA)).
//
// In the cell's unit coordinates p in [0, 1]^3 (mirrored in x for odd cells, which makes their
// corner tetrahedra those of an even cell), the corner tetrahedron at corner c is where the L1
// distance f_c(p) from c is below 1, with c in {000, 110, 101, 011}; the central tetrahedron is
// where all four f_c >= 1. Along the ray each f_c is linear, so the ray's stay in the central
// tetrahedron is an interval [c_in, c_out] inside the cell's [t_in, t_out], and the ray crosses at
// most three tetrahedra: a corner one, the central one, a corner one (passing from one corner
// tetrahedron to another directly would mean passing through an edge). The scalar is linear in
// each: the interpolation of its four corners. Each piece is integrated by segment.glsl, as
// projected tetrahedra integrate whole tetrahedra.
//
// Rays start on the near plane (t = 0), which clips cells in front of it.
// Second output (the depth image, with DEPTH_OUTPUT): as project.frag.glsl's, for the first piece
// with opacity.
#include "segment.glsl"
#include "raycasting/pixel_direction.glsl"

flat in vec4 unit_origin;  // cells.geom.glsl
flat in vec4 planes[5];
uniform vec3 spacing;
// the ray of the pixel centre (ndc_x, ndc_y) starts at near_point(ndc) (pixel_depth.glsl) and goes
// along ray_direction(ndc) (pixel_direction.glsl; Camera.rays)

layout(location = 0) out vec4 color;
#ifdef DEPTH_OUTPUT
layout(location = 1) out vec4 depth;
#endif

// f_c(p) for the corner tetrahedra of an even cell, c = 000, 110, 101, 011: CORNER_SLOPES * p +
// CORNER_OFFSETS (columns: the x, y and z slopes of the four).
const mat3x4 CORNER_SLOPES = mat3x4(vec4(1.0, -1.0, -1.0, 1.0), vec4(1.0, -1.0, 1.0, -1.0),
                                    vec4(1.0, 1.0, -1.0, -1.0));
const vec4 CORNER_OFFSETS = vec4(0.0, 2.0, 2.0, 2.0);

vec3 o, d;          // the ray in the cell's unit coordinates
vec3 origin, direction;
float scale;        // world length per unit of t

// Add the piece [a, b] of the ray (inside one tetrahedron) behind what color holds.
void add_piece(float a, float b) {
    if (!(b > a)) return;
    vec4 f_mid = CORNER_SLOPES * (o + 0.5 * (a + b) * d) + CORNER_OFFSETS;
    vec4 corner = vec4(lessThan(f_mid, vec4(1.0)));  // the corner tetrahedron holding it, if any
    vec4 plane = corner.x * planes[0] + corner.y * planes[1] + corner.z * planes[2]
                 + corner.w * planes[3] + (1.0 - dot(corner, vec4(1.0))) * planes[4];
    float at_origin = dot(plane.xyz, o) + plane.w, slope = dot(plane.xyz, d);
    vec4 piece = segment(at_origin + a * slope, at_origin + b * slope, (b - a) * scale);
#ifdef DEPTH_OUTPUT
    if (piece.a > 0.0 && depth.a == 0.0) {
        depth = point_depth(origin + a * direction, origin, 0.0);
    }
#endif
    color += (1.0 - color.a) * piece;
}

void main() {
    vec2 ndc = pixel_ndc();
    origin = near_point(ndc);
    direction = ray_direction(ndc);
    scale = length(direction);
    vec3 to_unit = vec3(unit_origin.w, 1.0, 1.0) / spacing;
    o = (origin - unit_origin.xyz) * to_unit;
    d = direction * to_unit;
    // The cell: slabs along the three axes (a zero direction component: an infinite slab crossing).
    vec3 safe_d = mix(d, vec3(1e-30), equal(d, vec3(0.0)));
    vec3 t_low = -o / safe_d, t_high = (1.0 - o) / safe_d;
    vec3 t_near = min(t_low, t_high), t_far = max(t_low, t_high);
    float t_in = max(max(max(t_near.x, t_near.y), t_near.z), 0.0);
    float t_out = min(min(t_far.x, t_far.y), t_far.z);
    if (!(t_out > t_in)) discard;  // the pixel's ray misses the cell (or meets it before the near plane)
    // The central tetrahedron's interval: every f_c(t) = f_o + t f_d >= 1.
    vec4 f_o = CORNER_SLOPES * o + CORNER_OFFSETS, f_d = CORNER_SLOPES * d;
    vec4 safe_f = mix(f_d, vec4(1e-30), equal(f_d, vec4(0.0)));
    vec4 crossing = (1.0 - f_o) / safe_f;
    vec4 lower = mix(vec4(-1e30), crossing, greaterThan(f_d, vec4(0.0)));
    vec4 upper = mix(vec4(1e30), crossing, lessThan(f_d, vec4(0.0)));
    float c_in = max(t_in, max(max(lower.x, lower.y), max(lower.z, lower.w)));
    float c_out = min(t_out, min(min(upper.x, upper.y), min(upper.z, upper.w)));
    bvec4 parallel = equal(f_d, vec4(0.0)), outside = lessThan(f_o, vec4(1.0));
    if (dot(vec4(parallel), vec4(outside)) > 0.0) c_out = c_in;  // parallel to a face, outside it
    color = vec4(0.0);
#ifdef DEPTH_OUTPUT
    depth = vec4(0.0);
#endif
    // Corner, central, corner (either corner piece may be empty); inside one corner tetrahedron
    // all the way, the first piece is the whole [t_in, t_out] and the other two are empty. Three
    // calls either way, not an if with one call and an else with three: a SIMD rasteriser (llvmpipe)
    // runs both branches for a block of pixels that disagree, four pieces' work for three.
    bool central = c_out > c_in;
    add_piece(t_in, central ? c_in : t_out);
    add_piece(c_in, central ? c_out : c_in);
    add_piece(central ? c_out : t_out, t_out);
}
