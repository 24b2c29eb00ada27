// A sample's weight in [0, 1] (vgraph.masking): the mask's (mask.glsl) times the cut-away's
// (cutaway.glsl). The compositing modes multiply a sample's opacity (dvr, first_hit) or intensity
// (mip, xray) by it, so a sample of weight 0 adds nothing. With neither MASK nor a CUTAWAY_* define
// it is the literal 1.0 (x * 1.0 == x exactly): images are unchanged bit for bit.
#include "raycasting/mask.glsl"
#include "raycasting/cutaway.glsl"
#if defined(MASK) || defined(CUTAWAY_BOX) || defined(CUTAWAY_SPHERE)
float sample_weight(vec3 t) {
    float weight = 1.0;
#ifdef MASK
    weight *= mask_weight(t);
#endif
#if defined(CUTAWAY_BOX) || defined(CUTAWAY_SPHERE)
    weight *= cutaway_weight(t);
#endif
    return weight;
}
#else
#define sample_weight(t) 1.0
#endif
