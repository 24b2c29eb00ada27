// COMPOSITING_MIP in one brick: the maximum of the normalised intensity (clamped to [0, 1]) over the
// samples the brick owns and the first sample holding it. The result goes out as (maximum, sample,
// 0, 1) with gl_FragDepth = 1 - maximum under a LESS depth test, so across bricks (drawn front to
// back) the largest maximum wins and a tie keeps the front brick: the RayCaster's first maximum.
// Classification happens once, in resolve.frag.glsl. A brick with nothing above 0 writes nothing.
#ifdef COMPOSITING_MIP
void composite(Ray ray, Span span, inout vec4 sum, inout float depth_sample) {  // (starts at 0)
    float best = 0.0;
    depth_sample = -1.0;
    for (int i = span.first; i <= span.last; ++i) {
        vec3 t = sample_point(ray, float(i));
        if (!owns(t)) {
            continue;
        }
        SKIP_BLOCK_IF(ray, t, i, range.y <= best)
        float value = min(intensity(t), 1.0);
        if (value > best) {
            best = value;
            depth_sample = float(i);
        }
    }
    sum = vec4(best, depth_sample, 0.0, 1.0);
}
#endif
