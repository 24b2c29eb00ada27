// Sobel gradient magnitude of one value per pixel (scipy.ndimage.sobel along each axis: the
// difference [-1, 0, 1] smoothed by [1, 2, 1] across, unnormalised; hypot of the two). Needs
// edge_texel.glsl and `float edge_value(vec4 texel)` (the channel the edges are taken of).
float sobel_magnitude(sampler2D image, ivec2 pixel) {
    float v[9];
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i)
            v[3 * j + i] = edge_value(edge_texel(image, pixel + ivec2(i - 1, j - 1)));
    float gx = (v[2] + 2.0 * v[5] + v[8]) - (v[0] + 2.0 * v[3] + v[6]);
    float gy = (v[6] + 2.0 * v[7] + v[8]) - (v[0] + 2.0 * v[1] + v[2]);
    return length(vec2(gx, gy));
}
