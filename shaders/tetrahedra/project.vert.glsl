#version 330
// Projected tetrahedra, vertex stage: one mesh point (x, y, z, normalised scalar) to clip space.
// Four consecutive vertices of the sorted index buffer (drawn as lines_adjacency) are one
// tetrahedron for project.geom.glsl.
in vec4 point;
uniform mat4 view_projection;
out vec4 v_point;

void main() {
    v_point = point;
    gl_Position = view_projection * vec4(point.xyz, 1.0);
}
