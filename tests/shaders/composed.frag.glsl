// Test fixture: includes, a repeated include, an include cycle and defines.
#version 330
#include "lib_a.glsl"
#include "lib_b.glsl"
out vec4 colour;

void main() {
#ifdef USE_B
    colour = vec4(lib_a(), lib_b(), SCALE, 1.0);
#else
    colour = vec4(lib_a(), 0.0, SCALE, 1.0);
#endif
}
