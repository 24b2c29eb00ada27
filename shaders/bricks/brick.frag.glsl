#version 330
// BrickSampling (the BrickedRayCaster, the RayCaster for a volume one texture cannot hold), one
// pass per brick (front to back): the samples of the pixel's ray that this
// brick owns (brick_span.glsl), composited by the mode's part (exactly one COMPOSITING_* of dvr,
// mip, iso; SHADING_BLINN_PHONG with one GRADIENT_* and LIGHT_HEADLIGHT; OPACITY_CORRECTION; for
// dvr READ_ACCUMULATION with EARLY_TERMINATION, front_state.glsl; SKIP_EMPTY_BLOCKS, brick_blocks.glsl).
// Outputs (vgraph.bricks.sampling sets blending or the depth test): `sum` = the
// premultiplied colour and coverage (mip: the maximum and its sample), `first` = (depth sample,
// 0, 0, 1) where there is one, else 0. Blended passes discard where the brick adds nothing; with
// READ_ACCUMULATION every pixel is written (the scratch targets are copied back whole).
// resolve.frag.glsl finishes the frame.
//
// The compositing is this shader's own part; the components' GLSL (pixel ray, camera rays and
// depth output, transfer function, the brick's sampling, span, blocks and front state, gradients,
// shading) is included ahead of it by the BrickSampling component (vgraph.bricks.sampling,
// BRICK_PARTS). sample_weight(t) (raycasting/sample_weight.glsl: the Mask and CutAway components,
// vgraph.gl.raycasting.mask) weighs each sample as in the RayCaster; t is the sample's level-0
// texture coordinate, the frame volume's, so the components' maps texture -> world apply unchanged.
#include "raycasting/sample_weight.glsl"
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
