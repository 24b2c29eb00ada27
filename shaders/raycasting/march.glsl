// The loop head of every mode that marches sample by sample (compositing dvr, mip, iso, first_hit,
// the curvature compositing and the curvature hit search): the samples i = 0 .. ray.samples - 1 of
// ray.glsl in order and, with SKIP_EMPTY_SPACE, the walk over the blocks of empty_space.glsl that
// jumps over empty regions. A mode writes
//
//     March cursor = start_march(ray);
//     while (cursor.i < ray.samples) {
//         if (!next_occupied_sample(cursor, ray)) break;  // past the empty regions at cursor.i
//         ... evaluate sample cursor.i (break or return when done) ...
//         ++cursor.i;
//     }
//
// (or skip_empty_space(), which says whether it moved, where a mode needs to know).
// Without SKIP_EMPTY_SPACE a March is only the index and both are literals (true, false),
// which the compiler removes: the loop is a plain march. With RAY_BOUNDS (ray_bounds.glsl; only for
// modes whose empty blocks contribute nothing, and never without SKIP_EMPTY_SPACE) start_march()
// also narrows the samples to those that may lie in an occupied block: it starts at the first and
// lowers ray.samples, so the loop head above stays as it is.
#include "raycasting/ray.glsl"
#include "raycasting/empty_space.glsl"
#include "raycasting/ray_bounds.glsl"

#ifdef RAY_BOUNDS
// The first sample in the bounds (one step to spare on each side for rounding); lowers ray.samples
// past the last one. Samples keep their positions start + i * step and the ones left out lie in
// empty blocks, so the image does not change. Needs depth_output.glsl (world_point, near_centre).
int bound_samples(inout Ray ray) {
    vec2 bounds = pixel_bounds();
    float start = dot(world_point(ray.start) - near_centre, view_forward);
    float per_sample = step_length * dot(ray.direction, view_forward);
    float first = floor((bounds.x - start) / per_sample) - 1.0;
    float last = ceil((-bounds.y - start) / per_sample) + 1.0;
    ray.samples = int(clamp(last + 1.0, 0.0, float(ray.samples)));
    return int(clamp(first, 0.0, float(ray.samples)));
}
#endif

struct March {
    int i;           // the sample to evaluate next
#ifdef SKIP_EMPTY_SPACE
    BlockWalk walk;  // for modes with their own rule on the block values (mip)
#elif defined(PAGED_SKIPPING)
    int run_end;     // samples before it lie in the run bricks/paged_sampling.glsl's paged_run() found
#ifdef PAGED_WALK
    BlockWalk walk;  // the frame's grid of skip radii over its bricks (paged_walk below)
    int block_end;   // samples before it lie in the occupied block of the grid the walk last read
#endif
#endif
};

#ifdef RAY_BOUNDS
March start_march(inout Ray ray) {
    March cursor;
    cursor.i = bound_samples(ray);
#else
March start_march(Ray ray) {
    March cursor;
    cursor.i = 0;
#endif
#ifdef SKIP_EMPTY_SPACE
    cursor.walk = block_walk(ray);
#elif defined(PAGED_SKIPPING)
    cursor.run_end = 0;
#ifdef PAGED_WALK
    cursor.walk = block_walk(ray);
    cursor.block_end = 0;
#endif
#endif
    return cursor;
}

#ifdef SKIP_EMPTY_SPACE
// Move cursor.i past the empty regions it lies in, all of them in a row, and return whether it
// moved. The jumps have a loop of their own: SIMD GL (llvmpipe's 8 lanes, a GPU's warp) runs the
// whole body of the caller's loop for all lanes in every pass, also for lanes that only jump, so
// a jump there would cost as much as a sample.
bool skip_empty_space(inout March cursor, Ray ray) {
    int before = cursor.i;
    while (cursor.i < ray.samples && skipped_empty_region(cursor.walk, cursor.i, ray.samples)) {}
    return cursor.i != before;
}

// skip_empty_space() for modes that only need the next sample to evaluate: false when the ray
// has none left.
bool next_occupied_sample(inout March cursor, Ray ray) {
    skip_empty_space(cursor, ray);
    return cursor.i < ray.samples;
}
#elif defined(PAGED_SKIPPING)
// The single-pass bricked ray caster's hook (bricks/paged_sampling.glsl, included ahead): a ray
// walks runs of samples, each inside one drawn cell (and block) of the page table, read from that
// cell's slot. Only a sample past the run looks the page table up, in a loop of its own (entered
// only when one of a SIMD group's rays leaves its run), which jumps over the cells and blocks that
// add nothing and starts the next run; with PAGED_REQUESTS a ray also asks there for the missing
// cells it reaches (bricks/ray_requests.glsl).
#ifdef PAGED_WALK
// A frame of dvr whose bricks are all in the atlas, or of iso with missing bricks (PAGED_WALK_ASKS;
// vgraph.bricks.walk_grids.skip_radii): the
// RayCaster's own walk over a frame-wide grid of skip radii jumps the empty regions, across cells,
// and the page table is looked up only where a sample of an occupied block leaves its run (a whole
// drawn cell: no PAGED_BLOCKS). One jump over the grid: past the empty region around cursor.i, or,
// in an occupied block, block_end set to the first sample past it.
void paged_jump(inout March cursor, Ray ray) {
    ivec3 block = block_of(cursor.walk, cursor.i);
    float radius = block_value(block);
#ifdef PAGED_WALK_ASKS
    // A refining frame (PAGED_REQUESTS): an empty block where a missing cell may start (radius < 0,
    // vgraph.bricks.walk_grids.ASKING; no jump enters one) starts a run, which asks for the cell as
    // the front-to-back march's run there does (or jumps the undrawn box as it does), and is left
    // block by block: the ray asks for every missing cell it has a sample in, in order, before any
    // sample in it, and none past where it stops. (dvr's refining frames march: walked this way
    // they asked for a few more pixels than the march, whose coarse cells take only their lattice's
    // samples, PAGED_STRIDE, and were slower: vgraph.bricks.walk_grids.)
    if (radius < 0.0) {
        int before = cursor.i;
        paged_run(cursor.i, cursor.run_end, ray);
        cursor.i = cursor.i != before ? cursor.i : next_sample_outside(cursor.walk, cursor.i, block, 1.0, ray.samples);
        return;
    }
#endif
    int next = next_sample_outside(cursor.walk, cursor.i, block, max(radius, 1.0), ray.samples);
    cursor.i = radius > 0.0 ? next : cursor.i;
    cursor.block_end = radius > 0.0 ? cursor.block_end : next;
}
#endif

#ifdef PAGED_ISO_GRID
// iso in a complete frame of level-0 bricks (compositing_iso.glsl; bricks/paged_sampling.glsl): move
// i past the empty regions it lies in, as skipped_empty_region does, in a loop of its own, and read
// the slot of the block it stops in, which the grid's texel names; whether it moved.
bool iso_grid_skip(BlockWalk walk, inout int i, int samples) {
    int before = i;
    vec4 texel = vec4(0.0);
    while (i < samples) {
        ivec3 block = block_of(walk, i);
        texel = texelFetch(blocks, block, 0);
        if (texel.r <= 0.0) break;
        i = next_sample_outside(walk, i, block, texel.r, samples);
    }
    read_block_slot(texel);
    return i != before;
}
#endif

// PAGED_STRIDE (bricks/paged_stride.glsl): a sample where the skips stop, inside a run of a coarse
// cell but between the samples its brick takes, moves on to the next one it takes (the one that
// stands for it lay in an empty block and was skipped: it adds nothing); may leave the run.
#ifdef PAGED_STRIDE
void stride_landing(inout March cursor) {
    cursor.i = cursor.i < cursor.run_end ? stride_from(cursor.i) : cursor.i;
}
#endif

bool skip_empty_space(inout March cursor, Ray ray) {
    int before = cursor.i;
#ifdef PAGED_WALK
    // The grid's jumps and the look-ups in loops of their own: in one loop body (an if and an else)
    // every pass of a SIMD group paid for both, the look-up for the 8 lanes at each jump of any one
    // (bonsai dvr 42 -> 37 ms of CPU). A look-up that jumps an undrawn cell (a block of the grid
    // that straddles cells) may land past the block: then both again.
    do {
        while (cursor.i < ray.samples && cursor.i >= cursor.block_end) {
            paged_jump(cursor, ray);
        }
        while (cursor.i < ray.samples && cursor.i < cursor.block_end && cursor.i >= cursor.run_end) {
            paged_run(cursor.i, cursor.run_end, ray);
        }
#ifdef PAGED_STRIDE
        stride_landing(cursor);
#endif
    } while (cursor.i < ray.samples && (cursor.i >= cursor.block_end || cursor.i >= cursor.run_end));
#elif defined(PAGED_STRIDE)
    do {
        while (cursor.i < ray.samples && cursor.i >= cursor.run_end) {
            paged_run(cursor.i, cursor.run_end, ray);
        }
        stride_landing(cursor);
    } while (cursor.i < ray.samples && cursor.i >= cursor.run_end);
#else
    while (cursor.i < ray.samples && cursor.i >= cursor.run_end) {
        paged_run(cursor.i, cursor.run_end, ray);
    }
#endif
    return cursor.i != before;
}

bool next_occupied_sample(inout March cursor, Ray ray) {
    skip_empty_space(cursor, ray);
    return cursor.i < ray.samples;
}

// The first sample past the run cursor.i lies in (after next_occupied_sample): the samples before
// it read the run's slot with no look-up, so a mode may take them in a loop of its own
// (compositing_dvr.glsl).
int run_stop(March cursor, Ray ray) {
    return min(cursor.run_end, ray.samples);
}
#else
// Literals, not functions returning them: Mesa then compiles exactly the plain loop (with a
// function the tricubic CurvatureVolumeRaycaster's colours moved by a float rounding, 4e-7).
#define skip_empty_space(cursor, ray) false
#define next_occupied_sample(cursor, ray) true
#endif
