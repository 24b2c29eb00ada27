// PagedSampling (issue #33, item 1; vgraph.bricks.paged_sampling): the volume sampled in one pass
// through a page table and a brick atlas. Same names as raycasting/volume_sampling.glsl
// (raw_sample, intensity, volume, intensity_scale/offset), so the RayCaster's compositing,
// gradients and shading work unchanged; march.glsl's PAGED_SKIPPING hook (always compiled here)
// calls paged_run() whenever a sample leaves its run.
//
// A ray walks runs: paged_run() reads the leaf entry of the sample's level-0 cell (the page
// table's walk from the top level down, done on the CPU: vgraph.bricks.leaf_pages, in a directory
// and pages where PAGE_DIRECTORY is defined, leaf_texel): a >= 1: drawn from the brick of level
// a - 1 in the atlas, rgb = the texel
// offset of its slot; a <= -1: nothing drawn (empty under the TF, or missing without a resident
// ancestor), and the walk stopped at level -a - 1, whose cell the ray jumps over. A drawn cell
// starts a run: the samples up to where the ray leaves the cell (or the cube of blocks of
// PAGED_BLOCKS) are read from its slot with no further look-up, their gradients too. Each slot's
// apron of 2 voxels holds what its own samples filter and what reads up to 1.5 voxels past its
// cell do (differences, iso's refinement), the voxels the neighbouring cell's brick holds, so level
// 0 equals the whole volume's texture. The look-ups are in a loop of their own: llvmpipe runs the
// code of an `if` for all 8 pixels of a SIMD group, but a loop only while one of them needs it
// (docs/reports/performance.md, "Code that no pixel needs is not free").
#define PAGE_FAR 1e6  // the volume's outer faces: samples on or a rounding past them have an owner

uniform sampler3D volume;        // the atlas
uniform sampler3D page_table;    // the leaf table, RGBA32F: its directory, then its pages
uniform float intensity_scale;   // normalised intensity = raw * scale + offset
uniform float intensity_offset;
uniform vec3 atlas_texels;                   // the atlas's size (x, y, z)
uniform vec3 slot_texels;                    // the atlas's slot shape (x, y, z)
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

// The run of samples the march is in (paged_run below): a stretch of the ray inside one drawn
// level-0 cell (and, with PAGED_BLOCKS, one block that adds something), read from that cell's
// slot. Set once per run, so a sample and its gradient's reads fetch no leaf entry.
vec3 run_scale;   // t -> normalised atlas coordinate: t * run_scale + run_offset
vec3 run_offset;

// Not clamped to the run's slot: every read lies within its cell's core and apron (above), and the
// clamp cost up to 5-8 % of a frame (torus 512^3 shaded dvr 231 -> 212 ms of CPU, mip 128 -> 120).
// The atlas's texel coordinate is a larger number than the in-core texture's, so the texture unit's
// weights round differently (up to ~1e-4 texel): samples differ in their last bits, which only
// ill-conditioned gradients show (tests/test_paged_ridge.py; weights by hand doubled the frame).
float raw_sample(vec3 t) {
    return textureLod(volume, t * run_scale + run_offset, 0.0).r;
}

// raw_sample() from now on reads the slot where the level's voxel coordinate t * scale + level
// offset lies at texel + texel_offset.
void read_from(vec3 scale, vec3 texel_offset) {
    run_scale = scale / atlas_texels;
    run_offset = texel_offset / atlas_texels;
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
// Skipping inside the atlas's bricks (vgraph.bricks.atlas_blocks, block_radii): per block of BLOCK^3
// core voxels of a slot and per octant of ray directions, k >= 1 where every block of the box from
// it k - 1 blocks ahead along each axis (in the volume) adds nothing this frame (a ray jumps over
// that box, across cell faces), -k where every block of that box in the slot may add something (a
// run spans it, cut at the cell: no look-up inside it); unknown blocks count as occupied. Slot s's
// blocks start at texel slot * blocks_per_slot of its octant's values.
#define PAGE_BLOCK 8.0
#define PAGE_APRON 2.0
uniform sampler3D block_flags;   // .g (PAGED_MIP): the block's largest normalised intensity
uniform ivec3 blocks_per_slot;
ivec3 block_octant;              // the ray's octant's values: ray_octant()
#ifdef PAGED_MIP
float paged_best = 0.0;          // the ray's running maximum: compositing_mip.glsl's plain march sets it
#endif

// The first texel of the values of the octant of directions `step` lies in (block_radii.py: the
// octants side by side, 2 x 2 x 2; a ray going down an axis reads the second half along it).
ivec3 ray_octant(vec3 step) {
    return ivec3(lessThan(step, vec3(0.0))) * (textureSize(block_flags, 0) / 2);
}

// [lo, hi) from the box of blocks [cube_lo, cube_hi) (only its faces ahead of the ray are its
// octant's): an empty box as it is, across the cell's faces (its distance counts the blocks of the
// neighbouring cells: vgraph.bricks.block_radii); an occupied box cut at the cell, whose slot the
// run reads.
void cube_box(bool empty, vec3 cube_lo, vec3 cube_hi, inout vec3 lo, inout vec3 hi) {
    lo = empty ? cube_lo : max(lo, cube_lo);
    hi = empty ? cube_hi : min(hi, cube_hi);
}

// Whether the sample at t, at atlas texel p of the slot whose first texel is `slot_origin`, lies in
// a block that adds nothing; narrows [lo, hi) to the box in t of the cube of blocks around it that
// all add nothing or all may add something (texel_offset, scale: t = (p - texel_offset) / scale).
bool in_empty_block(vec3 p, vec3 slot_origin, vec3 texel_offset, vec3 scale, inout vec3 lo, inout vec3 hi) {
    vec3 k = clamp(floor((p - slot_origin - PAGE_APRON) / PAGE_BLOCK), vec3(0.0), vec3(blocks_per_slot - 1));
    vec4 block = texelFetch(block_flags, ivec3(slot_origin / slot_texels + 0.5) * blocks_per_slot + ivec3(k) + block_octant, 0);
    float radius = block.r;
    float reach = abs(radius);
#ifdef PAGED_MIP
    // mip: an occupied block not above the ray's running maximum adds nothing either (its maximum,
    // .g, bounds every sample in it); runs are single blocks, so each one's maximum is asked
    reach = radius > 0.5 ? reach : 1.0;
    radius = radius < 0.5 && block.g <= paged_best ? 1.0 : radius;
#endif
    vec3 block_lo = (slot_origin + PAGE_APRON + k * PAGE_BLOCK - texel_offset) / scale;
    cube_box(radius > 0.5, block_lo - (reach - 1.0) * PAGE_BLOCK / scale, block_lo + reach * PAGE_BLOCK / scale, lo, hi);
    return radius > 0.5;
}
#endif

#include "bricks/ray_requests.glsl"
#include "bricks/paged_stride.glsl"  // PAGED_STRIDE: coarse cells on their own lattice (dvr)

// march.glsl's PAGED_SKIPPING hook, called whenever sample i is past the run (i >= run_end), in a
// loop of its own: looks up the leaf entry of sample i. Where its cell is not drawn (or, with
// PAGED_BLOCKS, its block adds nothing) moves i to the first sample past that box; else starts the
// run there: run_end = the first sample past the box, and the run's slot for raw_sample(). Samples
// skipped add nothing, so the image is the same; a sample a rounding past the box's face still
// lies within half a voxel of it, which the box's range and its slot's apron cover. Reads of a
// run's samples up to 1.5 voxels of its level outside the box (gradients' differences, iso's sample
// before a hit and its refinement, with sampling rates from 2/3) come from the slot's apron of 2
// voxels, the same voxels as the neighbouring cell's brick holds: at level 0 the in-core values.
// Every run starts here, so it is where a ray asks for the missing cells it reaches
// (ray_requests.glsl).
void paged_run(inout int i, inout int run_end, Ray ray) {
    vec3 t = sample_point(ray, float(i));
    request_missing(t);  // (PAGED_REQUESTS: a cell of the plan the atlas misses, reached here)
    vec4 entry = leaf_entry(t);
    bool drawn = entry.a > 0.0;
    // drawn: the level drawn, its level-0 cell; else: the cell where the walk stopped
    int level = int(abs(entry.a) + 0.5) - 1;
#ifdef PAGED_STRIDE
    int box_level = drawn ? stride_box_level(level) : level;  // (paged_stride.glsl)
#else
    int box_level = drawn ? 0 : level;
#endif
    vec3 lo, hi;
    cell_box(t, cell_scale[box_level], page_grid[box_level], lo, hi);
    vec3 scale = level_scale[level];
    vec3 texel_offset = level_offset[level] + entry.rgb;  // the level's voxel coordinate -> atlas texel
    vec3 slot_origin = floor((t * scale + texel_offset) / slot_texels) * slot_texels;
    bool skip = !drawn;
#ifdef PAGED_BLOCKS
    block_octant = ray_octant(ray.step);
    if (drawn) {
        skip = in_empty_block(t * scale + texel_offset, slot_origin, texel_offset, scale, lo, hi);
    }
#endif
#if defined(PAGED_REQUESTS) && defined(COMPOSITING_DVR)
    // dvr asks for every missing cell a ray has a sample in up to where it stops, whatever the
    // boxes: a run through an ancestor's whole cell (PAGED_STRIDE) or a jump over its empty blocks
    // would cross its missing level-0 cells unasked (which ones depended on empty_space_skipping),
    // so in a frame that asks every box ends at its level-0 cell.
    vec3 cell_lo, cell_hi;
    cell_box(t, cell_scale[0], page_grid[0], cell_lo, cell_hi);
    lo = max(lo, cell_lo);
    hi = min(hi, cell_hi);
#endif
    // Per axis, the sample index where the ray leaves the box (the face ahead of it).
    vec3 face = mix(lo, hi, step(vec3(0.0), ray.step));
    vec3 ahead = vec3(ray.step.x != 0.0 ? (face.x - ray.start.x) / ray.step.x : 1e30,
                      ray.step.y != 0.0 ? (face.y - ray.start.y) / ray.step.y : 1e30,
                      ray.step.z != 0.0 ? (face.z - ray.start.z) / ray.step.z : 1e30);
    float leave = min(min(ahead.x, ahead.y), ahead.z);
    int end = max(i + 1, int(min(ceil(leave), float(ray.samples))));
    if (skip) {
#ifdef PAGED_STRIDE
        if (drawn) {
            // A jump over a drawn cell's empty blocks lands where the march over all its blocks
            // would take its next sample (its brick's lattice, up to the brick's span), so the
            // next look-up, and what it asks for, is at the same sample as without the flags
            // (a jump in a stand-in's level-0 cell would else ask at a sample no run reaches).
            stride_run(t, entry, i, end, ray);
            end = max(end, min(stride_from(end), stride_end));
        }
#endif
        i = end;
    } else {
        run_end = end;
        read_from(scale, texel_offset);
#ifdef PAGED_STRIDE
        stride_run(t, entry, i, end, ray);
#endif
    }
}

#ifdef PAGED_MIP_WALK
// mip's passes over the grid of block maxima (compositing_mip.glsl) take stretches in any order, so
// the run raw_sample() reads is kept as [paged_run_start, paged_run_end): a stretch that starts in
// it looks nothing up.
int paged_run_start = 0;
int paged_run_end = 0;

// Sample j ready to read: its run's slot set, or j moved past the cells and blocks that add
// nothing (paged_run, in a loop of its own); false once j reaches `end`.
bool paged_ready(inout int j, int end, Ray ray) {
    while (j < end && (j < paged_run_start || j >= paged_run_end)) {
        int before = j;
        int run_end = j;
        paged_run(j, run_end, ray);
        if (j == before) {  // a run starts at j
            paged_run_start = j;
            paged_run_end = run_end;
        }
    }
    return j < end;
}
#endif

// Shaded iso (iso_refinement.glsl's iso_surface_colour): the gradient at the refined hit, which
// may lie up to a step before the run's cell, reads the slot of the hit's own cell where that cell
// is drawn (differences from the run's slot would reach 2 voxels past it, beyond its apron).
void paged_seat(vec3 t) {
    vec4 entry = leaf_entry(t);
    int level = max(int(entry.a + 0.5) - 1, 0);
    vec3 scale = level_scale[level];
    vec3 texel_offset = level_offset[level] + entry.rgb;
    if (entry.a > 0.0) {
        read_from(scale, texel_offset);
    }
}

#ifdef PAGED_ISO_GRID
// iso in a complete frame of level-0 bricks (vgraph.bricks.walk_grids.iso_grid; march.glsl's
// iso_grid_skip): the RayCaster's walk over its own blocks of 4 voxels (8, ... past 512^3), whose
// texels also say where their cell's slot is, so one fetch per sample says both whether to jump and
// where to read (no leaf table, no runs). r = the skip radius (0: the block may reach the level),
// gba = the normalised atlas coordinate t * dims0 / atlas_texels adds to read the block's cell's
// slot. A sample, iso's sample before a hit and its refinement (within a step of the hit: up to 1.5
// voxels at sampling rates from 2/3) read the hit's cell's slot, whose apron of 2 voxels holds
// them; the shaded gradient's reads go through paged_seat (its own cell).
uniform vec3 iso_read_scale;   // t -> normalised atlas coordinate, less the block's offset: dims0 / atlas_texels

// raw_sample() from now on reads the slot of the grid block whose texel is `texel`.
void read_block_slot(vec4 texel) {
    run_scale = iso_read_scale;
    run_offset = texel.gba;
}
#endif
