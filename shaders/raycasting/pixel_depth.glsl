// Where the pixel's ray starts and the depth of a point on it, for every renderer that writes the
// ray casters' depth output (depth_output.glsl; the tetrahedra renderers, tetrahedra/*.frag.glsl)
// and every pass that follows the pixels' rays (entry_exit_point.glsl, ray_bounds.frag.glsl,
// geometry/geometry_entry_exit.frag.glsl; their rays' direction: pixel_direction.glsl).
// Rays start on the near plane, as Camera.rays; a tile's pixels take the whole picture's rays
// (vgraph.gl.raycasting.geometry.pixel_rays binds these uniforms).
uniform mat4 view_projection;
uniform vec2 viewport_size;  // of the whole picture; pixel_offset: this image's place in it
uniform vec2 pixel_offset;   // (geometry.pixel_rays: a tile's rays are the whole picture's)
uniform vec3 near_centre;  // the pixel centre (ndc_x, ndc_y) is at near_centre + ndc_x near_right
uniform vec3 near_right;   // + ndc_y near_up on the near plane (where Camera.rays start)
uniform vec3 near_up;
uniform float world_length;  // world units per unit of the frame it is drawn in (an extreme box's
                             // or a mesh's normalised frame, framed_view, tetrahedra.frame; else 1)

// The normalised device coordinates in the whole picture of ``window``, a point in this image's
// window coordinates (ray_bounds.frag.glsl: the centre of a tile of pixels).
vec2 picture_ndc(vec2 window) {
    return (window + pixel_offset) / viewport_size * 2.0 - 1.0;
}

// The normalised device coordinates of this pixel's centre in the whole picture.
vec2 pixel_ndc() {
    return picture_ndc(gl_FragCoord.xy);
}

// Where the ray of the pixel centre at ``ndc`` starts, on the near plane.
vec3 near_point(vec2 ndc) {
    return near_centre + ndc.x * near_right + ndc.y * near_up;
}

// The depth output at ``point`` of a ray that starts at ``origin``: (window-space depth in [0, 1],
// the distance in world units, ``taken``, 1).
vec4 point_depth(vec3 point, vec3 origin, float taken) {
    vec4 clip = view_projection * vec4(point, 1.0);
    return vec4(clip.z / clip.w * 0.5 + 0.5, distance(point, origin) * world_length, taken, 1.0);
}
