#version 330
#include "broken_lib.glsl"
out vec4 colour;
void main() { colour = vec4(broken_lib()); }
