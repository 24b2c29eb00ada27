// RayRequests (issue #33, item 2; vgraph.bricks.ray_requests): with PAGED_REQUESTS, the cells of
// the frame's plan that the atlas does not hold and that a ray reached are counted, one count per
// ray (a pixel), in `requests`, laid out as the page table (level L's cells at z + page_z_offset[L]);
// the CPU reads it back after the frame and loads what rays asked for. A ray asks at every sample it
// evaluates and at the start of every jump (paged_skipped), so a cell behind the sample where the ray
// stopped (early termination, mip's maximum of 1) is never asked for. Included by paged_sampling.glsl.
#ifdef PAGED_REQUESTS
uniform sampler3D wanted_table;           // per level-0 cell: 1 + the level of the planned cell there
                                          // that the atlas misses, 0 where none is missing
layout(r32ui) uniform uimage3D requests;  // rays that reached each missing cell
uniform int page_z_offset[PAGE_LEVELS];
ivec3 last_request = ivec3(-1);           // this ray's last counted cell: a ray counts a cell once

void request_missing(vec3 t) {
    float wanted = texelFetch(wanted_table, clamp(ivec3(floor(t * leaf_scale)), ivec3(0), leaf_grid - 1), 0).r;
    if (wanted > 0.5) {
        int level = int(wanted + 0.5) - 1;
        ivec3 cell = clamp(ivec3(floor(t * cell_scale[level])), ivec3(0), page_grid[level] - 1);
        cell.z += page_z_offset[level];
        if (cell != last_request) {
            imageAtomicAdd(requests, cell, 1u);
            last_request = cell;
        }
    }
}
#else
#define request_missing(t)
#endif
