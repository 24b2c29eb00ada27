#version 330
// Test fixture: line 9 uses an undeclared variable on purpose.
#include "lib_a.glsl"
in vec2 uv;
out vec4 colour;

void main() {
    float a = lib_a();
    colour = vec4(undeclared_on_purpose, a, 0.0, 1.0);
}
