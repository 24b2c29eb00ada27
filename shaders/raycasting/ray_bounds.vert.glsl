#version 330
// Ray bounds (vgraph.gl.raycasting.ray_bounds): one instance of the unit cube per box of occupied
// blocks, into a target of one texel per tile of ray_bounds_tile^2 pixels. The box is grown by the
// farthest any ray of a tile gets from the tile's centre ray within the box's depth (so the centre
// ray's interval in the grown box holds those of all the tile's rays), and drawn grown by
// `coverage_margin` more so that every texel whose centre ray meets the grown box gets a fragment
// whatever the rasteriser's rounding; the fragment intersects its ray with the grown box itself.
in vec3 corner;   // 0 or 1 per axis
in vec3 box_min;  // world, per instance
in vec3 box_max;

uniform mat4 view_projection;  // world -> clip of the full image
uniform vec2 coarse_scale;     // full-image NDC + 1 -> tile-target NDC + 1
uniform vec3 coverage_margin;  // world, per axis
uniform vec3 near_centre;      // rays start on the near plane through near_centre, ...
uniform vec3 view_forward;     // ... whose normal this is; a ray's parameter s is its depth from it
uniform float tile_near;       // the farthest a tile's ray is from its centre ray at s = 0
uniform float tile_spread;     // ... and how much farther per unit of s

flat out vec3 lo;
flat out vec3 hi;

void main() {
    vec3 half_size = 0.5 * (box_max - box_min);
    float deepest = dot(box_min + half_size - near_centre, view_forward) + dot(half_size, abs(view_forward));
    float grow = tile_near + max(deepest, 0.0) * tile_spread;
    lo = box_min - grow;
    hi = box_max + grow;
    vec4 clip = view_projection * vec4(mix(lo - coverage_margin, hi + coverage_margin, corner), 1.0);
    clip.xy = (clip.xy + clip.w) * coarse_scale - clip.w;
    // Not clipped by the far plane: a box reaching past it still bounds the rays that end there
    // (vertices behind the near plane keep z < -w and are clipped as they must be).
    clip.z = min(clip.z, clip.w);
    gl_Position = clip;
}
