#version 330
// Cell projection of a mesh cut from a regular grid, vertex stage: one kept cell per vertex (the
// index buffer holds the cells in sweep order; vgraph.gl.tetrahedra.cells).
in vec4 cell;           // (corner 0 in world units, parity of i + j + k)
in vec4 scalars_low;    // normalised scalars of corners 0..3 (corner c at (c & 1, c >> 1 & 1, c >> 2 & 1))
in vec4 scalars_high;   // corners 4..7
out vec4 v_cell;
out vec4 v_scalars_low;
out vec4 v_scalars_high;

void main() {
    v_cell = cell;
    v_scalars_low = scalars_low;
    v_scalars_high = scalars_high;
    gl_Position = vec4(cell.xyz, 1.0);
}
