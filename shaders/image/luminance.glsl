// Luminance 0.30 R + 0.59 G + 0.11 B (Cabral 2010, code 4.5), the Grayscale processor's weights.
float luminance(vec3 rgb) {
    return dot(rgb, vec3(0.30, 0.59, 0.11));
}
