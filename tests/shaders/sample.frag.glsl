#version 330
// Test fixture: colour_matrix * texture(source) * gain. unused_tex is declared but never read, so
// the compiler removes it and a pass must skip it.
in vec2 uv;
out vec4 colour;
uniform sampler2D source;
uniform sampler2D unused_tex;
uniform float gain;
uniform mat4 colour_matrix;

void main() {
    colour = colour_matrix * texture(source, uv) * gain;
}
