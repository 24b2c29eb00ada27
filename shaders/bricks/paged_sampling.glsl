// PagedSampling (issue #33, item 1; vgraph.bricks.paged_sampling): the volume sampled in one pass
// through a page table and a brick atlas. Same names as raycasting/volume_sampling.glsl
// (raw_sample, intensity, volume, intensity_scale/offset), so the RayCaster's compositing,
// gradients and shading work unchanged; march.glsl's PAGED_SKIPPING hook calls paged_skipped() to
// jump over cells that add nothing.
//
// A sample at level-0 texture coordinate t reads the leaf table's entry of its level-0 cell
// (vgraph.bricks.page_table.PageTable.resolve: the page table's walk from the top level down,
// done on the CPU): a >= 1: drawn from the brick of level a - 1 in the atlas, rgb = the texel
// offset of its slot; a <= -1: nothing drawn (empty under the TF, or missing without a resident
// ancestor), r = a normalised intensity that adds nothing, and the walk stopped at level -a - 1,
// whose cell a ray may jump over. No branch decides what to fetch: llvmpipe would run its code for
// every sample anyway (docs/reports/performance.md, "Code that no pixel needs is not free").
// Reads near a cell's faces (trilinear, gradients) come from the slot of the cell they fall in;
// each slot's apron of 2 voxels holds what its own samples filter, so level 0 equals the whole
// volume's texture.
#define PAGE_FAR 1e6  // the volume's outer faces: samples on or a rounding past them have an owner

uniform sampler3D volume;        // the atlas
uniform sampler3D page_table;    // the leaf table, RGBA32F, one texel per level-0 cell
uniform float intensity_scale;   // normalised intensity = raw * scale + offset
uniform float intensity_offset;
uniform vec3 atlas_texels;                   // the atlas's size (x, y, z)
uniform ivec3 leaf_grid;                     // level 0's cells per axis (page_grid[0], cell_scale[0]:
uniform vec3 leaf_scale;                     //   apart, as a compiler trims an array read at 0 only)
uniform ivec3 page_grid[PAGE_LEVELS];        // cells per axis of each level
uniform vec3 cell_scale[PAGE_LEVELS];        // t -> cell coordinates: level-0 voxels / cell span
uniform vec3 level_scale[PAGE_LEVELS];       // t -> the level's voxel coordinate u = t * scale + offset
uniform vec3 level_offset[PAGE_LEVELS];

ivec3 cell_of(vec3 t, int level) {
    return clamp(ivec3(floor(t * cell_scale[level])), ivec3(0), page_grid[level] - 1);
}

vec4 leaf_entry(vec3 t) {
    return texelFetch(page_table, clamp(ivec3(floor(t * leaf_scale)), ivec3(0), leaf_grid - 1), 0);
}

float raw_sample(vec3 t) {
    vec4 entry = leaf_entry(t);
    int level = max(int(entry.a + 0.5) - 1, 0);  // (a cell not drawn fetches something: see the top)
    vec3 texel = t * level_scale[level] + level_offset[level] + entry.rgb;
    float fetched = textureLod(volume, texel / atlas_texels, 0.0).r;
    return entry.a > 0.0 ? fetched : (entry.r - intensity_offset) / intensity_scale;
}

float intensity(vec3 t) {
    return raw_sample(t) * intensity_scale + intensity_offset;
}

// Where sample i lies in a cell that is not drawn, move i to the first sample past the cell where
// the walk stopped and return true (march.glsl's PAGED_SKIPPING hook jumps until this returns
// false).
bool paged_skipped(inout int i, Ray ray) {
    vec3 t = sample_point(ray, float(i));
    vec4 entry = leaf_entry(t);
    if (entry.a > 0.0) {
        return false;
    }
    int level = int(-entry.a + 0.5) - 1;
    ivec3 cell = cell_of(t, level);
    ivec3 last = page_grid[level] - 1;
    vec3 lo = mix(vec3(cell) / cell_scale[level], vec3(-PAGE_FAR), equal(cell, ivec3(0)));
    vec3 hi = mix(vec3(cell + 1) / cell_scale[level], vec3(PAGE_FAR), equal(cell, last));
    // Per axis, the sample index where the ray leaves the box (the face ahead of it).
    vec3 face = mix(lo, hi, step(vec3(0.0), ray.step));
    vec3 ahead = vec3(ray.step.x != 0.0 ? (face.x - ray.start.x) / ray.step.x : 1e30,
                      ray.step.y != 0.0 ? (face.y - ray.start.y) / ray.step.y : 1e30,
                      ray.step.z != 0.0 ? (face.z - ray.start.z) / ray.step.z : 1e30);
    float leave = min(min(ahead.x, ahead.y), ahead.z);
    i = max(i + 1, int(min(ceil(leave), float(ray.samples))));
    return true;
}
