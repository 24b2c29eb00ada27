#version 330
// Far-plane capping: pixels whose point on the far plane lies inside the (grown) box get a fragment
// here, because the back face the ray would leave the box through was clipped away. (The near
// plane needs none: a ray that enters the box behind it still leaves through a back face.)
#include "raycasting/entry_exit_point.glsl"

uniform vec3 cap_centre;  // the pixel centre (ndc_x, ndc_y) is at centre + ndc_x right + ndc_y up
uniform vec3 cap_right;
uniform vec3 cap_up;
uniform vec3 proxy_min;   // world corners of the grown box
uniform vec3 proxy_max;

layout(location = 0) out vec4 entry;
layout(location = 1) out vec4 exit;

void main() {
    vec2 ndc = pixel_ndc();
    vec3 world = cap_centre + ndc.x * cap_right + ndc.y * cap_up;
    if (any(lessThan(world, proxy_min)) || any(greaterThan(world, proxy_max))) {
        discard;
    }
    box_points(entry, exit);
}
