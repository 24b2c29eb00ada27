// The surface's colour before lighting: COLORING_UNIFORM the `surface_color` uniform,
// COLORING_VERTEX the vertex colours, COLORING_SCALAR the vertex scalar through the colour map
// (a 256-entry LUT, linear between entries; values outside scalar_low .. scalar_high clamp to
// the ends).
#ifdef COLORING_SCALAR
uniform sampler2D colormap;
uniform float scalar_low;
uniform float scalar_high;
#define COLORMAP_SIZE 256.0

vec3 surface_color(vec4 vertex_color, float scalar) {
    float t = clamp((scalar - scalar_low) / (scalar_high - scalar_low), 0.0, 1.0);
    return texture(colormap, vec2((0.5 + t * (COLORMAP_SIZE - 1.0)) / COLORMAP_SIZE, 0.5)).rgb;
}
#elif defined(COLORING_VERTEX)
vec3 surface_color(vec4 vertex_color, float scalar) {
    return vertex_color.rgb;
}
#else
uniform vec4 surface_color_uniform;

vec3 surface_color(vec4 vertex_color, float scalar) {
    return surface_color_uniform.rgb;
}
#endif
