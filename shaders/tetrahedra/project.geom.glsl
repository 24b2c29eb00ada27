#version 330
// Projected tetrahedra (Shirley & Tuchman 1990; Monsalve 2016 ch. 3), geometry stage: classify
// the tetrahedron's projection and emit the triangles of its silhouette, fanned from the thick
// point (vgraph.gl.tetrahedra.projection has the rule and the 81-entry class table), as
// triangle strips: 5 vertices for class 1, 5 + 3 for class 2.
//
// mu_i = (-1)^i det(other three projected vertices) satisfy sum mu_i (p_i, 1) = 0. The vertices
// with mu > 0 form one group, the others the second (signs flipped when three are positive, so the
// + group is the smaller). The thick point q = sum |mu_i| p_i / sum |mu_i| over either group: the
// odd vertex (class 1) or the crossing of the two edges (class 2); the limit classes 3 and 4 come
// out of the same formulas. Triangles (q, p_i, p_j): pairs inside the larger group for 1 + 3,
// pairs across the groups for 2 + 2 (the ring alternates between the groups).
//
// Every attribute is handed to the fragment stage in homogeneous form, (X / w, 1 / w) and s / w
// with w the clip w of the point, and interpolated without perspective over triangles whose
// positions have w = 1: on each plane of a face that is exact for both projections (the
// projective map keeps planes, and X / w, 1 / w are affine in the image). The thick point carries
// the two points on its ray, one from each group; the silhouette vertices carry their own point
// twice (thickness 0). The ray enters through one face and leaves through another over each
// triangle, so the fragment stage gets the exact front and back points of its pixel's ray.
layout(lines_adjacency) in;
layout(triangle_strip, max_vertices = 8) out;

in vec4 v_point[];
noperspective out vec4 front_h;   // (X_front / w, 1 / w)
noperspective out vec4 back_h;    // (X_back / w, 1 / w)
noperspective out vec2 scalar_h;  // (s_front / w_front, s_back / w_back)
flat out vec3 limits;             // (depth extent along view_forward, scalar min, scalar max)
uniform vec3 view_forward;

vec2 p[4];
vec4 h[4];   // (X / w, 1 / w) of the vertices
float sh[4]; // s / w
float zn[4]; // NDC depth

float det2(vec2 a, vec2 b, vec2 c) {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

vec3 tet_limits;

void silhouette_vertex(int i) {
    limits = tet_limits;
    front_h = h[i];
    back_h = h[i];
    scalar_h = vec2(sh[i]);
    gl_Position = vec4(p[i], 0.0, 1.0);  // z = 0: near and far do not clip (docs)
    EmitVertex();
}

void thick_vertex(vec2 q, vec4 front, vec4 back, vec2 scalars) {
    limits = tet_limits;
    front_h = front;
    back_h = back;
    scalar_h = scalars;
    gl_Position = vec4(q, 0.0, 1.0);
    EmitVertex();
}

void main() {
    for (int i = 0; i < 4; ++i) {
        vec4 clip = gl_in[i].gl_Position;
        if (clip.w <= 0.0) return;  // a vertex behind the eye: the tetrahedron is not drawn
        float inv_w = 1.0 / clip.w;
        p[i] = clip.xy * inv_w;
        zn[i] = clip.z * inv_w;
        h[i] = vec4(v_point[i].xyz * inv_w, inv_w);
        sh[i] = v_point[i].w * inv_w;
    }
    // What no segment inside the tetrahedron can exceed (the fragment stage clamps to it: where a
    // face is seen almost edge-on, float32 interpolation across its sliver can overshoot).
    vec4 depths = vec4(dot(v_point[0].xyz, view_forward), dot(v_point[1].xyz, view_forward),
                       dot(v_point[2].xyz, view_forward), dot(v_point[3].xyz, view_forward));
    vec4 scalars = vec4(v_point[0].w, v_point[1].w, v_point[2].w, v_point[3].w);
    tet_limits = vec3(max(max(depths.x, depths.y), max(depths.z, depths.w))
                  - min(min(depths.x, depths.y), min(depths.z, depths.w)),
                  min(min(scalars.x, scalars.y), min(scalars.z, scalars.w)),
                  max(max(scalars.x, scalars.y), max(scalars.z, scalars.w)));
    float mu[4];
    mu[0] = det2(p[1], p[2], p[3]);
    mu[1] = -det2(p[0], p[2], p[3]);
    mu[2] = det2(p[0], p[1], p[3]);
    mu[3] = -det2(p[0], p[1], p[2]);
    int positive = 0;
    for (int i = 0; i < 4; ++i) positive += mu[i] > 0.0 ? 1 : 0;
    if (positive == 0 || positive == 4) return;  // flat projection: no area
    if (positive == 3) {
        for (int i = 0; i < 4; ++i) mu[i] = -mu[i];
        positive = 0;
        for (int i = 0; i < 4; ++i) positive += mu[i] > 0.0 ? 1 : 0;
        if (positive == 0) return;  // 3 positive and 1 zero cannot sum to 0: rounding, no area
    }
    // The two groups' points on the ray through q, in homogeneous form.
    float weight_a = 0.0, weight_b = 0.0;
    for (int i = 0; i < 4; ++i) {
        if (mu[i] > 0.0) weight_a += mu[i]; else weight_b -= mu[i];
    }
    if (weight_a <= 0.0 || weight_b <= 0.0) return;
    vec2 q = vec2(0.0);
    vec4 ha = vec4(0.0), hb = vec4(0.0);
    float sa = 0.0, sb = 0.0, za = 0.0, zb = 0.0;
    for (int i = 0; i < 4; ++i) {
        if (mu[i] > 0.0) {
            float l = mu[i] / weight_a;
            q += l * p[i];
            ha += l * h[i];
            sa += l * sh[i];
            za += l * zn[i];
        } else {
            float l = -mu[i] / weight_b;
            hb += l * h[i];
            sb += l * sh[i];
            zb += l * zn[i];
        }
    }
    bool a_in_front = za <= zb;  // NDC depth grows away from the eye in both projections
    vec4 thick_front = a_in_front ? ha : hb;
    vec4 thick_back = a_in_front ? hb : ha;
    vec2 thick_scalar = a_in_front ? vec2(sa, sb) : vec2(sb, sa);

    // The silhouette ring: 1 + 3, the group of three in any order; 2 + 2, alternating groups.
    int a = 0, b = 0;
    int group_a[4], group_b[4];
    for (int i = 0; i < 4; ++i) {
        if (mu[i] > 0.0) group_a[a++] = i; else group_b[b++] = i;
    }
    if (positive == 1) {
        // Strip b0 b1 q b2 b0: triangles (b0, b1, q), (b1, q, b2), (q, b2, b0).
        silhouette_vertex(group_b[0]);
        silhouette_vertex(group_b[1]);
        thick_vertex(q, thick_front, thick_back, thick_scalar);
        silhouette_vertex(group_b[2]);
        silhouette_vertex(group_b[0]);
        EndPrimitive();
    } else {
        // Ring a0 b0 a1 b1 around q. Strip a0 b0 q a1 b1: (a0, b0, q), (b0, q, a1), (q, a1, b1);
        // then the triangle (q, b1, a0).
        silhouette_vertex(group_a[0]);
        silhouette_vertex(group_b[0]);
        thick_vertex(q, thick_front, thick_back, thick_scalar);
        silhouette_vertex(group_a[1]);
        silhouette_vertex(group_b[1]);
        EndPrimitive();
        thick_vertex(q, thick_front, thick_back, thick_scalar);
        silhouette_vertex(group_b[1]);
        silhouette_vertex(group_a[0]);
        EndPrimitive();
    }
}
