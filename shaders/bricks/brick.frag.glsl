#version 330
// BrickedRayCaster, one pass per brick (front to back): the samples of the pixel's ray that this
// brick owns (brick_span.glsl), composited by the mode's part (exactly one COMPOSITING_* of dvr,
// mip, iso; SHADING_BLINN_PHONG with one GRADIENT_* and LIGHT_HEADLIGHT; OPACITY_CORRECTION; for
// dvr READ_ACCUMULATION with EARLY_TERMINATION, front_state.glsl; SKIP_EMPTY_BLOCKS, brick_blocks.glsl).
// Outputs (processors/bricked_raycaster.py sets blending or the depth test): `sum` = the
// premultiplied colour and coverage (mip: the maximum and its sample), `first` = (depth sample,
// 0, 0, 1) where there is one, else 0. Blended passes discard where the brick adds nothing; with
// READ_ACCUMULATION every pixel is written (the scratch targets are copied back whole).
// resolve.frag.glsl finishes the frame.
#include "raycasting/ray.glsl"
#include "raycasting/pixel_ray.glsl"
#include "raycasting/depth_output.glsl"  // the camera uniforms of CameraRays (unused here)
#include "raycasting/transfer_function.glsl"
#include "bricks/brick_sampling.glsl"
#include "raycasting/gradients.glsl"
#include "raycasting/shading.glsl"
#include "bricks/brick_span.glsl"
#include "bricks/brick_blocks.glsl"
#include "bricks/front_state.glsl"
#include "bricks/composite_dvr.glsl"
#include "bricks/composite_mip.glsl"
#include "bricks/composite_iso.glsl"

layout(location = 0) out vec4 sum;
layout(location = 1) out vec4 first;

#ifdef READ_ACCUMULATION
#define NOTHING_HERE() { write(sum_here, depth_sample); return; }
#else
#define NOTHING_HERE() discard
#endif

void write(vec4 sum_here, float depth_sample) {
    sum = sum_here;
    first = depth_sample >= 0.0 ? vec4(depth_sample, 0.0, 0.0, 1.0) : vec4(0.0);
}

void main() {
    vec4 sum_here;
    float depth_sample;
    front_state(sum_here, depth_sample);
    Ray ray;
    if (!pixel_ray(ray)) {
        NOTHING_HERE();
    }
    Span span = owned_span(ray);
    if (span.first > span.last) {
        NOTHING_HERE();
    }
    composite(ray, span, sum_here, depth_sample);
#ifndef READ_ACCUMULATION
    if (depth_sample < 0.0) {
        discard;  // nothing here: the accumulation stays as the bricks in front left it
    }
#endif
#ifdef COMPOSITING_MIP
    gl_FragDepth = 1.0 - sum_here.r;
#endif
    write(sum_here, depth_sample);
}
