// The zero-curvature contour (Cabral 2010: JET with the zero contour in black). The distance in pixels
// from a pixel to the zero of the measure is estimated to first order as |k| / |grad k|, with the
// screen-space gradient from the neighbouring pixels of the curvature image (central differences,
// one-sided at the surface's edge, 0 where no neighbour has a defined curvature). The contour is
// `contour_width` pixels wide: black where that distance is <= width/2 - 1/2, fading to no
// darkening at width/2 + 1/2 (antialiased); k == 0 is always on it. Width 0 draws nothing.
uniform sampler2D curvature_image;
uniform float contour_width;  // pixels

float measure_at(ivec2 pixel, out bool defined) {
    ivec2 size = textureSize(curvature_image, 0);
    bool inside = all(greaterThanEqual(pixel, ivec2(0))) && all(lessThan(pixel, size));
    vec4 c = texelFetch(curvature_image, clamp(pixel, ivec2(0), size - 1), 0);
    defined = inside && c.a == 1.0;
    return curvature_measure(c);
}

float screen_derivative(ivec2 pixel, ivec2 axis, float here) {
    bool up_ok, down_ok;
    float up = measure_at(pixel + axis, up_ok);
    float down = measure_at(pixel - axis, down_ok);
    if (up_ok && down_ok) return 0.5 * (up - down);
    if (up_ok) return up - here;
    if (down_ok) return here - down;
    return 0.0;
}

// 1 on the contour, 0 away from it.
float contour_weight(ivec2 pixel, float k) {
    if (!(contour_width > 0.0)) {
        return 0.0;
    }
    vec2 slope = vec2(screen_derivative(pixel, ivec2(1, 0), k),
                      screen_derivative(pixel, ivec2(0, 1), k));
    float steepness = length(slope);
    float distance_px = k == 0.0 ? 0.0 : (steepness > 0.0 ? abs(k) / steepness : 1.0e30);
    return 1.0 - clamp(distance_px - (0.5 * contour_width - 0.5), 0.0, 1.0);
}
