// lib_a: includes lib_b, which includes lib_a back (a cycle).
#include "lib_b.glsl"
float lib_a() { return 1.0; }
