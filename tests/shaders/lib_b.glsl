#include "lib_a.glsl"
float lib_b() { return 2.0; }
