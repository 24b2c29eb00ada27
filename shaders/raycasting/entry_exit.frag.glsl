#version 330
// The back faces of the box (the front ones are culled): each fragment intersects its pixel's ray
// with the box and writes both of its points (entry_exit_point.glsl). Back faces, because every
// ray that meets the box in front of the camera leaves it through one, also with the near plane
// cutting the box (a camera inside); where the far plane cuts it, plane_cap.frag.glsl adds the
// pixels whose back face was clipped.
#include "raycasting/entry_exit_point.glsl"

layout(location = 0) out vec4 entry;
layout(location = 1) out vec4 exit;

void main() {
    box_points(entry, exit);
}
