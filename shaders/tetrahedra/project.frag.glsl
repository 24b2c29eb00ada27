#version 330
// Projected tetrahedra, fragment stage: the ray integral across one tetrahedron from the front and
// back points of the pixel's ray (project.geom.glsl), premultiplied for "over" blending back to
// front (glBlendFunc(ONE, ONE_MINUS_SRC_ALPHA)).
//
// The integral itself (averaged or pre-integrated): segment.glsl.
//
// Second output (the depth image, with DEPTH_OUTPUT: only when something reads it): (window depth of the front point, its distance from the ray's
// start on the near plane, 0, 1) where alpha > 0, else 0, which the blending leaves as it was: the
// last tetrahedron with opacity drawn, the nearest in the visibility order, wins.
#include "segment.glsl"
#include "raycasting/pixel_depth.glsl"

noperspective in vec4 front_h;
noperspective in vec4 back_h;
noperspective in vec2 scalar_h;
flat in vec3 limits;  // (depth extent of the tetrahedron along view_forward, scalar min, max)
uniform vec3 view_forward;

layout(location = 0) out vec4 color;
#ifdef DEPTH_OUTPUT
layout(location = 1) out vec4 depth;
#endif

void main() {
    vec3 x_front = front_h.xyz / front_h.w;
    vec3 x_back = back_h.xyz / back_h.w;
    float s_front = clamp(scalar_h.x / front_h.w, limits.y, limits.z);
    float s_back = clamp(scalar_h.y / back_h.w, limits.y, limits.z);
    // Near-plane clipping: the pixel's ray starts on the near plane (as Camera.rays and the cell
    // path); a segment that begins in front of it begins there, one wholly in front is nothing.
    float near_front = dot(x_front - near_centre, view_forward);
    float near_back = dot(x_back - near_centre, view_forward);
    if (near_back <= 0.0 && near_front <= 0.0) discard;
    if (near_front < 0.0) {
        float f = near_front / (near_front - near_back);
        x_front = mix(x_front, x_back, f);
        s_front = mix(s_front, s_back, f);
    }
    // A segment inside the tetrahedron spans at most its depth extent along the view direction;
    // beyond it (a ray grazing a face seen almost edge-on), shorten it to that.
    float thickness = distance(x_front, x_back);
    float across = abs(dot(x_back - x_front, view_forward));
    if (across > limits.x) thickness *= limits.x / across;
    color = segment(s_front, s_back, thickness);
#ifdef DEPTH_OUTPUT
    if (color.a > 0.0) {
        depth = point_depth(x_front, near_point(pixel_ndc()), 0.0);
    } else {
        depth = vec4(0.0);
    }
#endif
}
