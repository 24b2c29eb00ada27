#version 330
// A triangle mesh in world coordinates (vgraph.geometry.Geometry) seen by the camera: the
// fragment stage gets the world position and normal, and the vertex's colour or scalar.
uniform mat4 view_projection;
in vec3 position;
in vec3 normal;
in vec4 vertex_color;
in float scalar;
out vec3 world;
out vec3 world_normal;
out vec4 color_in;
out float scalar_in;

void main() {
    world = position;
    world_normal = normal;
    color_in = vertex_color;
    scalar_in = scalar;
    gl_Position = view_projection * vec4(position, 1.0);
}
