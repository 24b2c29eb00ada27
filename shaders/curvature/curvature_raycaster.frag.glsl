#version 330
// CurvatureRaycaster, pass 1 (Cabral 2010 sec. 5.4): the iso-surface at `level` between the
// EntryExitPoints images, its curvature from the selected derivative mode, and what the colour
// pass needs. Composed from the RayCaster's parts (ray set-up, volume sampling, empty-space
// skipping) and the curvature parts; the defines choose exactly one field (DERIVATIVES_FORWARD,
// _CENTRAL, _FILTERED or _TRICUBIC with optional TRICUBIC_FAST) and SKIP_EMPTY_SPACE. Code of the
// other derivative modes is not compiled.
//
// Outputs (RGBA32F):
//   curvature  (k1, k2, K) in 1/world units (H = (k1 + k2) / 2 is not stored: alpha is the flag);
//              alpha 1 where the ray hit and the curvature is defined, 0.5 where it hit but the
//              curvature is undefined (rgb 0), 0 on a miss
//   position   world-space hit point, alpha 1 where the ray hit (else 0)
//   depth      the RayCaster's depth output at the hit (else (1, 0, samples, 0))
//   gradient   (internal) gradient in normalised intensity per world unit, alpha 1 where hit
//
// Its own part; the GLSL of its components (pixel ray, camera rays and depth output, volume sampling,
// the curvature field, empty space) is included ahead of it by RaycasterBase.draw.
#include "raycasting/march.glsl"
#include "curvature/iso_hit.glsl"

uniform float min_gradient;  // |grad f| at or below this (per world unit): undefined

layout(location = 0) out vec4 curvature;
layout(location = 1) out vec4 position;
layout(location = 2) out vec4 depth;
layout(location = 3) out vec4 gradient;

void main() {
    curvature = vec4(0.0);
    position = vec4(0.0);
    gradient = vec4(0.0);
    depth = no_depth(0);
    Ray ray;
    if (!pixel_ray(ray)) {
        return;
    }
    Hit hit = find_hit(ray);
    depth.b = float(hit.taken);
    if (!hit.found) {
        return;
    }
    vec3 g;
    mat3 h;
    field_derivatives(hit.point, g, h);
    vec4 k;
    bool defined = kindlmann_curvature(g, h, min_gradient, k);
    curvature = vec4(k.xyz, defined ? 1.0 : 0.5);
    vec3 world = world_point(hit.point);
    position = vec4(world, 1.0);
    depth = depth_of(world, hit.taken);
    bool finite_gradient = all(lessThan(abs(g), vec3(3.0e38)));
    gradient = vec4(finite_gradient ? g : vec3(0.0), 1.0);
}
