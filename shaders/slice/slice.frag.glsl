#version 330
// SliceViewer: one pass over the output image; each pixel is a point of the slice plane, sampled
// from the volume (slice/reconstruction.glsl) and mapped to a colour (slice/mapping.glsl).
// The plane arrives in voxel coordinates (voxel (i, j, k) at p = (i, j, k)), computed in float64
// by vgraph.slicing: p = voxel_centre + (u - 0.5) voxel_right + (v - 0.5) voxel_up, with (u, v)
// the pixel centre's image coordinate (v up, GL's bottom row first). Pixels outside the volume's
// cells ([-0.5, n - 0.5] on every axis) are transparent black.
#include "slice/reconstruction.glsl"
#include "slice/mapping.glsl"

uniform vec2 image_size;    // width, height in pixels
uniform vec3 voxel_centre;  // voxel coordinate of the image centre
uniform vec3 voxel_right;   // voxel-coordinate vector from the left edge to the right edge
uniform vec3 voxel_up;      // ... from the bottom edge to the top edge
uniform vec3 volume_size;   // voxels per axis (x, y, z)
#ifdef SLAB
uniform vec3 voxel_normal;   // voxel-coordinate vector of one sample step along the normal
uniform int slab_half_steps; // samples on either side of the plane
#endif
#ifdef CROSSHAIR
uniform vec2 cursor_pixel;  // the cursor in window coordinates (gl_FragCoord units)
uniform vec4 crosshair_color;
#endif
out vec4 color;

bool in_cells(vec3 p) {
    return all(greaterThanEqual(p, vec3(-0.5))) && all(lessThanEqual(p, volume_size - 0.5));
}

// The plane's intensity, or with SLAB the largest one over the slab (thick-slab MIP): samples one
// step apart along the normal on either side, those outside the cells skipped.
float slab_intensity(vec3 p) {
    float value = intensity_at(p);
#ifdef SLAB
    for (int k = 1; k <= slab_half_steps; ++k) {
        vec3 offset = float(k) * voxel_normal;
        if (in_cells(p + offset)) value = max(value, intensity_at(p + offset));
        if (in_cells(p - offset)) value = max(value, intensity_at(p - offset));
    }
#endif
    return value;
}

void main() {
    vec2 uv = gl_FragCoord.xy / image_size;  // pixel centres: (c + 0.5) / width, exactly
    vec3 p = voxel_centre + (uv.x - 0.5) * voxel_right + (uv.y - 0.5) * voxel_up;
    bool inside = in_cells(p);
    color = inside ? mapped(slab_intensity(p)) : vec4(0.0);
#ifdef CROSSHAIR
    // The row and the column of pixels that hold the cursor: one pixel wide at any zoom (a
    // cursor on a pixel border belongs to the pixel above / to the right).
    bvec2 on_cursor = equal(ivec2(floor(gl_FragCoord.xy)), ivec2(floor(cursor_pixel)));
    if (any(on_cursor)) {
        color = crosshair_color;
    }
#endif
}
