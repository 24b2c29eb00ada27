// A background colour (premultiplied) at a pixel of an image `height` rows high, chosen by define:
// PATTERN_GRADIENT `first` at the top row's centre ... `second` at the bottom row's, linear in the
// row (t = (row + 0.5) / height, row 0 at the top); PATTERN_CHECKERBOARD squares of `cell` pixels
// from the top-left corner, `first` there; otherwise `first` throughout.
uniform vec4 first;
uniform vec4 second;
uniform int cell;
uniform int height;

vec4 background_at(ivec2 pixel) {
    int row = height - 1 - pixel.y;  // GL counts rows from the bottom
#if defined(PATTERN_GRADIENT)
    return mix(first, second, (float(row) + 0.5) / float(height));
#elif defined(PATTERN_CHECKERBOARD)
    return ((pixel.x / cell + row / cell) % 2 == 0) ? first : second;
#else
    return first;
#endif
}
