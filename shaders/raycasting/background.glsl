// The background under the composited colour (premultiplied colour and coverage over it).
uniform vec4 background;

vec4 over_background(vec4 color) {
    return vec4(color.rgb + (1.0 - color.a) * background.rgb, color.a + (1.0 - color.a) * background.a);
}
