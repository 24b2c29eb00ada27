#version 330
// Test fixture: the colour depends on defines. RED is a float define, GREEN_ON a flag.
in vec2 uv;
out vec4 colour;
void main() {
#ifdef GREEN_ON
    float green = 1.0;
#else
    float green = 0.0;
#endif
    colour = vec4(RED, green, 0.0, 1.0);
}
