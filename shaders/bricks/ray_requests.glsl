// RayRequests (issue #33, item 2; vgraph.bricks.ray_requests): with PAGED_REQUESTS, the cells of
// the frame's plan that the atlas does not hold and that a ray reached are counted, one count per
// ray (a pixel), in `requests`, one counter per missing cell (cell i at texel (i % request_row,
// i / request_row, 0)); the CPU reads it back after the frame and loads what rays asked for. A ray
// asks at the start of every run and every jump (paged_run: a run lies in one level-0 cell; in
// dvr a jump too, so it asks for every cell it has a sample in, with empty_space_skipping or
// without), so a cell behind the sample where the ray stopped (early termination, mip's maximum of
// 1) is never asked for. Included by paged_sampling.glsl (after leaf_texel).
#ifdef PAGED_REQUESTS
uniform sampler3D wanted_table;           // laid out as the leaf table (leaf_texel): 1 + the index
                                          // of the missing planned cell there, 0 where none is
layout(r32ui) uniform uimage3D requests;  // rays that reached each missing cell
uniform int request_row;
int last_request = -1;                    // this ray's last counted cell: a ray counts a cell once

void request_missing(vec3 t) {
    int wanted = int(texelFetch(wanted_table, leaf_texel(t), 0).r + 0.5) - 1;
    if (wanted >= 0 && wanted != last_request) {
        imageAtomicAdd(requests, ivec3(wanted % request_row, wanted / request_row, 0), 1u);
        last_request = wanted;
    }
}
#else
#define request_missing(t)
#endif
