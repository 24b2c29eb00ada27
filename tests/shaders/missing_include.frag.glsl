#version 330
out vec4 colour;
#include "does_not_exist.glsl"
void main() { colour = vec4(1.0); }
