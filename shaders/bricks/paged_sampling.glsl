// PagedSampling (issue #33, item 1; vgraph.bricks.paged_sampling): the volume sampled in one pass
// through a page table and a brick atlas. Same names as raycasting/volume_sampling.glsl
// (raw_sample, intensity, volume, intensity_scale/offset), so the RayCaster's compositing,
// gradients and shading work unchanged; march.glsl's PAGED_SKIPPING hook calls paged_skipped() to
// jump over cells that add nothing.
//
// A sample at level-0 texture coordinate t reads the leaf entry of its level-0 cell (the page
// table's walk from the top level down, done on the CPU: vgraph.bricks.leaf_pages, in a directory
// and pages where PAGE_DIRECTORY is defined, leaf_texel): a >= 1: drawn from the brick of level a - 1 in the atlas, rgb = the texel
// offset of its slot; a <= -1: nothing drawn (empty under the TF, or missing without a resident
// ancestor), r = a normalised intensity that adds nothing, and the walk stopped at level -a - 1,
// whose cell a ray may jump over. No branch decides what to fetch: llvmpipe would run its code for
// every sample anyway (docs/reports/performance.md, "Code that no pixel needs is not free").
// Reads near a cell's faces (trilinear, gradients) come from the slot of the cell they fall in;
// each slot's apron of 2 voxels holds what its own samples filter, so level 0 equals the whole
// volume's texture.
#define PAGE_FAR 1e6  // the volume's outer faces: samples on or a rounding past them have an owner

uniform sampler3D volume;        // the atlas
uniform sampler3D page_table;    // the leaf table, RGBA32F: its directory, then its pages
uniform float intensity_scale;   // normalised intensity = raw * scale + offset
uniform float intensity_offset;
uniform vec3 atlas_texels;                   // the atlas's size (x, y, z)
uniform ivec3 leaf_grid;                     // level 0's cells per axis (page_grid[0], cell_scale[0]:
uniform vec3 leaf_scale;                     //   apart, as a compiler trims an array read at 0 only)
uniform ivec3 page_grid[PAGE_LEVELS];        // cells per axis of each level
uniform vec3 cell_scale[PAGE_LEVELS];        // t -> cell coordinates: level-0 voxels / cell span
uniform vec3 level_scale[PAGE_LEVELS];       // t -> the level's voxel coordinate u = t * scale + offset
uniform vec3 level_offset[PAGE_LEVELS];

#ifdef PAGE_DIRECTORY
#define PAGE_POINTER 1024.0      // vgraph.bricks.leaf_pages.POINTER
uniform ivec3 page_cells;        // level-0 cells per directory cell (x, y, z)
#endif

// The texel of the leaf entry of t's level-0 cell: without PAGE_DIRECTORY the table is flat (one
// texel per level-0 cell); with it, the directory entry of the cell's directory cell is final, or
// a pointer (a = PAGE_POINTER) to the page holding its level-0 cells at rgb. No branch: a select.
ivec3 leaf_texel(vec3 t) {
    ivec3 cell = clamp(ivec3(floor(t * leaf_scale)), ivec3(0), leaf_grid - 1);
#ifdef PAGE_DIRECTORY
    ivec3 directory = cell / page_cells;
    vec4 entry = texelFetch(page_table, directory, 0);
    return entry.a >= PAGE_POINTER ? ivec3(entry.rgb) + cell - directory * page_cells : directory;
#else
    return cell;
#endif
}

vec4 leaf_entry(vec3 t) {
    return texelFetch(page_table, leaf_texel(t), 0);
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

// The box (in t, half-open) of the cell of t in a grid of `grid` cells, `scale` cells per unit of t;
// the volume's outer faces pushed to PAGE_FAR.
void cell_box(vec3 t, vec3 scale, ivec3 grid, out vec3 lo, out vec3 hi) {
    ivec3 cell = clamp(ivec3(floor(t * scale)), ivec3(0), grid - 1);
    lo = mix(vec3(cell) / scale, vec3(-PAGE_FAR), equal(cell, ivec3(0)));
    hi = mix(vec3(cell + 1) / scale, vec3(PAGE_FAR), equal(cell, grid - 1));
}

#ifdef PAGED_BLOCKS
// Skipping inside the atlas's bricks (vgraph.bricks.atlas_blocks): 1 where a block of BLOCK^3 core
// voxels of a slot adds nothing this frame; slot s's blocks start at texel slot * blocks_per_slot.
#define PAGE_BLOCK 8.0
#define PAGE_APRON 2.0
uniform sampler3D block_flags;
uniform vec3 slot_texels;        // the atlas's slot shape (x, y, z)
uniform ivec3 blocks_per_slot;

// Whether the drawn sample at t (leaf entry `entry`) lies in a block that adds nothing; if so its
// box in t, within the level-0 cell of t (a block may reach past the cells its brick draws).
bool in_empty_block(vec3 t, vec4 entry, inout vec3 lo, inout vec3 hi) {
    int level = max(int(entry.a + 0.5) - 1, 0);
    vec3 p = t * level_scale[level] + level_offset[level] + entry.rgb;  // atlas texels
    vec3 slot = floor(p / slot_texels);
    vec3 k = clamp(floor((p - slot * slot_texels - PAGE_APRON) / PAGE_BLOCK), vec3(0.0),
                   vec3(blocks_per_slot - 1));
    bool empty = texelFetch(block_flags, ivec3(slot) * blocks_per_slot + ivec3(k), 0).r > 0.5;
    vec3 block_lo = (slot * slot_texels + PAGE_APRON + k * PAGE_BLOCK - level_offset[level] - entry.rgb)
                    / level_scale[level];
    lo = max(lo, block_lo);
    hi = min(hi, block_lo + PAGE_BLOCK / level_scale[level]);
    return empty;
}
#endif

#include "bricks/ray_requests.glsl"

// Where sample i lies in a cell that is not drawn (or, with PAGED_BLOCKS, in a block that adds
// nothing), move i to the first sample past that box and return true (march.glsl's
// PAGED_SKIPPING hook jumps until this returns false). Samples skipped add nothing, so the image
// is the same; a sample a rounding past the box's face still lies within half a voxel of it,
// whose range covers it. Every sample a mode evaluates passes here first, so it is where a ray
// asks for the missing cells it reaches (ray_requests.glsl).
bool paged_skipped(inout int i, Ray ray) {
    vec3 t = sample_point(ray, float(i));
    request_missing(t);  // (PAGED_REQUESTS: a cell of the plan the atlas misses, reached here)
    vec4 entry = leaf_entry(t);
    vec3 lo, hi;
    bool skip;
    if (entry.a > 0.0) {
#ifdef PAGED_BLOCKS
        cell_box(t, leaf_scale, leaf_grid, lo, hi);
        skip = in_empty_block(t, entry, lo, hi);
#else
        skip = false;
#endif
    } else {
        int level = int(-entry.a + 0.5) - 1;  // the cell where the walk stopped
        cell_box(t, cell_scale[level], page_grid[level], lo, hi);
        skip = true;
    }
    if (!skip) {
        return false;
    }
    // Per axis, the sample index where the ray leaves the box (the face ahead of it).
    vec3 face = mix(lo, hi, step(vec3(0.0), ray.step));
    vec3 ahead = vec3(ray.step.x != 0.0 ? (face.x - ray.start.x) / ray.step.x : 1e30,
                      ray.step.y != 0.0 ? (face.y - ray.start.y) / ray.step.y : 1e30,
                      ray.step.z != 0.0 ? (face.z - ray.start.z) / ray.step.z : 1e30);
    float leave = min(min(ahead.x, ahead.y), ahead.z);
    i = max(i + 1, int(min(ceil(leave), float(ray.samples))));
    return true;
}
