#version 330
// One pass of the GPU min/max reduction of the curvature image (vgraph.gl.curvature.RangeReduction):
// output pixel (x, y) reduces the source block [x, x + n) x [y, y + n), n = reduce_block.
// REDUCE_FIRST: the source is the curvature image; pixels with alpha 1 (hit, curvature defined)
// contribute their curvature_measure() (one CURVATURE_* define). Later passes: the source holds
// (min, max, count, 1) per pixel. The last pass returns (min(min, 0), max(max, 0), count, 1), the
// kmin and kmax of the normalisation (0, 0 where no pixel counted).
#include "curvature/measure.glsl"

uniform sampler2D source;
uniform ivec2 source_size;
uniform int reduce_block;
uniform bool last_pass;

out vec4 range;

void main() {
    ivec2 base = ivec2(gl_FragCoord.xy) * reduce_block;
    ivec2 end = min(base + reduce_block, source_size);
    float low = 3.0e38, high = -3.0e38, count = 0.0;
    for (int y = base.y; y < end.y; ++y) {
        for (int x = base.x; x < end.x; ++x) {
            vec4 texel = texelFetch(source, ivec2(x, y), 0);
#ifdef REDUCE_FIRST
            if (texel.a == 1.0) {
                float k = curvature_measure(texel);
                low = min(low, k);
                high = max(high, k);
                count += 1.0;
            }
#else
            if (texel.z > 0.0) {
                low = min(low, texel.x);
                high = max(high, texel.y);
                count += texel.z;
            }
#endif
        }
    }
    range = last_pass ? vec4(min(low, 0.0), max(high, 0.0), count, 1.0) : vec4(low, high, count, 1.0);
}
