#version 330
// EntryExitPoints (Inacio 2009 ch. 4.2.2, Krueger & Westermann 2003): the volume's box as the 12
// triangles of a unit cube (counter-clockwise seen from outside) scaled into world space, grown
// by a margin so that every pixel whose ray meets the box gets a fragment whatever the
// rasteriser's rounding. The fragments compute their points exactly (entry_exit_point.glsl).
in vec3 corner;  // 0 or 1 per axis

uniform vec3 proxy_min;  // world corners of the grown box
uniform vec3 proxy_size;
uniform mat4 view_projection;  // world -> clip

void main() {
    gl_Position = view_projection * vec4(proxy_min + corner * proxy_size, 1.0);
}
