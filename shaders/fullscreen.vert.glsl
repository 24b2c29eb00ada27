#version 330
// One triangle that covers the whole viewport, drawn with three vertices and no vertex buffer:
// gl_VertexID 0, 1, 2 -> clip-space (-1,-1), (3,-1), (-1,3). The part outside [-1,1]^2 is clipped.
// uv is the texture coordinate of the target image: (0,0) at the bottom-left corner, (1,1) at the
// top-right (GL convention; vgraph.image.Image.to_numpy flips so that row 0 is the top).
out vec2 uv;

void main() {
    vec2 clip = vec2(float((gl_VertexID & 1) * 4 - 1), float((gl_VertexID & 2) * 2 - 1));
    uv = clip * 0.5 + 0.5;
    gl_Position = vec4(clip, 0.0, 1.0);
}
