#version 330
// CurvatureRaycaster, pass 2: colour from the curvature image of pass 1. The measure (one
// CURVATURE_* define) is normalised (NORMALIZATION_*; linear reads kmin, kmax from the 1 x 1
// `curvature_range` texture of the GPU reduction), coloured by the colour map, optionally shaded
// (SHADING_BLINN_PHONG, raycasting/shading.glsl, with the gradient of pass 1) and darkened on
// the zero contour. Pixels where the ray hit but the curvature is undefined (alpha 0.5) get
// `undefined_color`; misses get `background`. Output alpha 1 where hit.
// Its own part; the GLSL of its components (curvature colouring, shading, background) is included
// ahead of it by RaycasterBase.draw.
#include "curvature/contour.glsl"

uniform sampler2D gradient_image;
uniform sampler2D position_image;
uniform sampler2D curvature_range;
uniform vec4 undefined_color;
uniform vec3 eye;           // world: the camera position (perspective)
uniform vec3 view_forward;  // world, unit: the view direction (orthographic)
uniform bool perspective;

out vec4 color;

void main() {
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(curvature_image, pixel, 0);
    if (c.a == 0.0) {
        color = background;
        return;
    }
    if (c.a != 1.0) {
        color = vec4(undefined_color.rgb, 1.0);
        return;
    }
    float k = curvature_measure(c);
    vec2 range = texelFetch(curvature_range, ivec2(0), 0).xy;
    vec3 rgb = colormap_color(normalized_curvature(k, range));
#ifdef SHADING_BLINN_PHONG
    vec3 world = texelFetch(position_image, pixel, 0).xyz;
    vec3 to_eye = eye - world;
    vec3 view = perspective && dot(to_eye, to_eye) > 0.0 ? normalize(to_eye) : -view_forward;
    rgb = shade(rgb, texelFetch(gradient_image, pixel, 0).xyz, view);
#endif
    rgb *= 1.0 - contour_weight(pixel, k);
    color = vec4(rgb, 1.0);
}
