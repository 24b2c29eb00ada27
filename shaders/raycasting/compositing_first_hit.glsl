// COMPOSITING_FIRST_HIT: first-hit points (as Voreen's FHP): the texture coordinates of the first
// sample whose opacity is > 0 (TF, gradient opacity or 2D TF), as rgb with alpha 1 (the encoding of
// the entry/exit images), for later passes. Depth: that sample. With SKIP_EMPTY_SPACE, blocks of zero opacity are skipped.
#include "raycasting/gradient_classification.glsl"  // classify_sample()
#ifdef COMPOSITING_FIRST_HIT
Result march(Ray ray) {
    Result result = empty_result();
    March cursor = start_march(ray);
    while (cursor.i < ray.samples) {
        if (!next_occupied_sample(cursor, ray)) break;
        vec3 t = sample_point(ray, float(cursor.i));
        result.taken++;
        if (classify_sample(t, intensity(t)).a * sample_weight(t) > 0.0) {  // gradient_classification.glsl
            result.color = vec4(t, 1.0);
            result.depth_sample = float(cursor.i);
            return result;
        }
        ++cursor.i;
    }
    return result;
}
#endif
