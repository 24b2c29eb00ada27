// COMPOSITING_DVR: direct volume rendering, front-to-back (Inacio 2009 eq. 2.3-2.4):
// C += (1 - A) a' rgb, A += (1 - A) a' with a' the opacity-corrected TF alpha, shaded colour where
// SHADING_BLINN_PHONG (only samples with a' > 0 are shaded: the others add nothing). The ray stops
// once A >= early_termination. Depth: the first sample with a' > 0. With SKIP_EMPTY_SPACE, regions
// of blocks where the TF has no opacity are jumped over (empty_space.glsl).
#ifdef COMPOSITING_DVR
uniform float early_termination;

Result march(Ray ray) {
    Result result = empty_result();
    vec4 sum = vec4(0.0);
    March cursor = start_march(ray);
#ifdef SHADING_BLINN_PHONG
    // First the samples up to the first visible one, in a loop without the shading code: SIMD GL
    // runs a branch for a whole group of pixels when one of them takes it (a GPU's warp) or always
    // (llvmpipe's 8 lanes), so in a single loop rays still in empty space would pay for shading.
    while (cursor.i < ray.samples) {
        if (!next_occupied_sample(cursor, ray)) break;
        if (classify(intensity(sample_point(ray, float(cursor.i)))).a > 0.0) break;
        result.taken++;
        ++cursor.i;
    }
#endif
    while (cursor.i < ray.samples) {
        if (!next_occupied_sample(cursor, ray)) break;
        vec3 t = sample_point(ray, float(cursor.i));
        vec4 texel = shading_texel(t);  // raw value in .a (gradients.glsl)
        vec4 color = classify(texel.a * intensity_scale + intensity_offset);
        result.taken++;
        if (color.a > 0.0) {
            float alpha = corrected_opacity(color.a);
#ifdef SHADING_BLINN_PHONG
            color.rgb = shade(color.rgb, texel_gradient(t, texel), -ray.direction);
#endif
            if (result.depth_sample < 0.0) {
                result.depth_sample = float(cursor.i);
            }
            float weight = (1.0 - sum.a) * alpha;
            sum += vec4(weight * color.rgb, weight);
            if (sum.a >= early_termination) {
                break;
            }
        }
        ++cursor.i;
    }
    result.color = sum;
    return result;
}
#endif
