#version 330
// Near-plane capping (entry points) and far-plane capping (exit points): pixels whose point on the
// clipping plane lies inside the (grown) box get a fragment here, because the face the ray would
// enter (leave) the box through was clipped away (e.g. the camera is inside the volume).
#include "raycasting/entry_exit_point.glsl"

uniform vec3 cap_centre;  // the pixel centre (ndc_x, ndc_y) is at centre + ndc_x right + ndc_y up
uniform vec3 cap_right;
uniform vec3 cap_up;
uniform vec3 proxy_min;   // world corners of the grown box
uniform vec3 proxy_max;

out vec4 point;

void main() {
    vec2 ndc = pixel_ndc();
    vec3 world = cap_centre + ndc.x * cap_right + ndc.y * cap_up;
    if (any(lessThan(world, proxy_min)) || any(greaterThan(world, proxy_max))) {
        discard;
    }
    point = box_point();
}
