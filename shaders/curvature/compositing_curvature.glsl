// Compositing of the CurvatureVolumeRaycaster (Cabral 2010 sec. 5.5): front-to-back direct volume
// rendering (the RayCaster's dvr: C += (1 - A) a' rgb, A += (1 - A) a', early termination), where
// the opacity a' comes from the scalar transfer function of the sample's normalised intensity
// (march_value(); opacity-corrected for the sampling rate) and the colour from the normalised
// curvature of the level set through the sample: colormap_color(normalized_curvature(measure)),
// or `undefined_color` where the curvature is undefined; shaded with SHADING_BLINN_PHONG.
// Derivatives and curvature are computed only for samples with a' > 0.
//
// RANGE_PASS (linear normalisation, first pass): the same march, but the result is the range of
// the measure over the samples that contribute (a' > 0, curvature defined, before early
// termination): (min, max, count, 1), reduced over the image by RangeReduction.
// Depth: the first sample with a' > 0. With SKIP_EMPTY_SPACE, regions of blocks where the TF has
// no opacity are jumped over (empty_space.glsl).
#include "raycasting/gradient_classification.glsl"  // classify_sample()

uniform float early_termination;
uniform float min_gradient;  // |grad f| at or below this (per world unit): curvature undefined
uniform vec4 undefined_color;
uniform sampler2D curvature_range;  // 1 x 1: (kmin, kmax) of the linear normalisation

Result march(Ray ray) {
    Result result = empty_result();
    vec4 sum = vec4(0.0);
    vec3 range = vec3(3.0e38, -3.0e38, 0.0);  // min, max, count
#if defined(NORMALIZATION_LINEAR) && !defined(RANGE_PASS)
    vec2 kmin_kmax = texelFetch(curvature_range, ivec2(0), 0).xy;
#else
    vec2 kmin_kmax = vec2(0.0);
#endif
    March cursor = start_march(ray);
    while (cursor.i < ray.samples) {
        if (!next_occupied_sample(cursor, ray)) break;
        vec3 t = sample_point(ray, float(cursor.i));
        vec4 classified = classify_sample(t, march_value(t) * intensity_scale + intensity_offset);
        classified.a *= sample_weight(t);  // 0: masked or cut away (raycasting/sample_weight.glsl)
        result.taken++;
        if (classified.a > 0.0) {
            float alpha = corrected_opacity(classified.a);
            vec3 g;
            mat3 h;
            field_derivatives(t, g, h);
            vec4 k;
            bool defined = kindlmann_curvature(g, h, min_gradient, k);
            float measure = curvature_measure(k);
#ifdef RANGE_PASS
            if (defined) {
                range = vec3(min(range.x, measure), max(range.y, measure), range.z + 1.0);
            }
            vec3 rgb = vec3(0.0);
#else
            vec3 rgb = defined ? colormap_color(normalized_curvature(measure, kmin_kmax))
                               : undefined_color.rgb;
#ifdef SHADING_BLINN_PHONG
            rgb = shade(rgb, g, -ray.direction);
#endif
#endif
            if (result.depth_sample < 0.0) {
                result.depth_sample = float(cursor.i);
            }
            float weight = (1.0 - sum.a) * alpha;
            sum += vec4(weight * rgb, weight);
            if (sum.a >= early_termination) {
                break;
            }
        }
        ++cursor.i;
    }
#ifdef RANGE_PASS
    result.color = vec4(range, 1.0);
#else
    result.color = sum;
#endif
    return result;
}
