#version 330
// The front faces (entry points) or back faces (exit points) of the box, face culling chooses
// which. Each fragment intersects its pixel's ray with the box (entry_exit_point.glsl).
#include "raycasting/entry_exit_point.glsl"

out vec4 point;

void main() {
    point = box_point();
}
