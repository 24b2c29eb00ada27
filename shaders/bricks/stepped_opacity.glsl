// A sample's opacity standing for `weight` steps of level 0 (FrontToBack's opacity_exponent per
// step): 1 - (1 - a)^(exponent * weight), the composite of `weight` level-0 samples of that value,
// in the stable form that keeps small opacities; a weight of 1 is corrected_opacity itself (level 0
// stays the RayCaster's sum). A coarse brick's samples, brick by brick (brick_span.glsl) and in
// the single pass (paged_stride.glsl). Needs transfer_function.glsl.
float stepped_opacity(float alpha, int weight) {
    if (weight == 1) {
        return corrected_opacity(alpha);
    }
    return alpha >= 1.0 ? 1.0 : corrected_alpha(alpha, opacity_exponent * float(weight));  // raycasting/opacity.glsl
}
