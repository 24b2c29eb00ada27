// A texel of `image` at an integer pixel, the pixel clamped into the image: the border mode
// 'nearest' of scipy.ndimage (the edge pixel repeats), which the image filters' tests compare with.
vec4 edge_texel(sampler2D image, ivec2 pixel) {
    return texelFetch(image, clamp(pixel, ivec2(0), textureSize(image, 0) - 1), 0);
}
