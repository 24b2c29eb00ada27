#version 330
// BrickedRayCaster, one pass per brick (front to back): the samples of the pixel's ray that this
// brick owns (brick_span.glsl), composited by the mode's part (exactly one COMPOSITING_* of dvr,
// mip, iso; SHADING_BLINN_PHONG with one GRADIENT_* and LIGHT_HEADLIGHT; OPACITY_CORRECTION).
// Outputs, blended into the accumulation targets (processors/bricked_raycaster.py sets the blend):
// `sum` = the brick's premultiplied colour and coverage (mip: its maximum and sample), `first` =
// (depth sample, 0, 0, 1) where the brick has one, else 0. resolve.frag.glsl finishes the frame.
#include "raycasting/ray.glsl"
#include "raycasting/pixel_ray.glsl"
#include "raycasting/depth_output.glsl"  // the camera uniforms of CameraRays (unused here)
#include "raycasting/transfer_function.glsl"
#include "bricks/brick_sampling.glsl"
#include "raycasting/gradients.glsl"
#include "raycasting/shading.glsl"
#include "bricks/brick_span.glsl"
#include "bricks/composite_dvr.glsl"
#include "bricks/composite_mip.glsl"
#include "bricks/composite_iso.glsl"

layout(location = 0) out vec4 sum;
layout(location = 1) out vec4 first;

void main() {
    Ray ray;
    if (!pixel_ray(ray)) {
        discard;
    }
    Span span = owned_span(ray);
    if (span.first > span.last) {
        discard;
    }
    float depth_sample;
    composite(ray, span, sum, depth_sample);
    if (depth_sample < 0.0) {
        discard;  // nothing here: the accumulation stays as the bricks in front left it
    }
#ifdef COMPOSITING_MIP
    gl_FragDepth = 1.0 - sum.r;
#endif
    first = vec4(depth_sample, 0.0, 0.0, 1.0);
}
