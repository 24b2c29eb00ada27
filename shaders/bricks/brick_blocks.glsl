// SKIP_EMPTY_BLOCKS: empty-space skipping inside a brick (BrickedRayCaster). The brick's blocks of
// BLOCK^3 core voxels carry the normalised min and max of every voxel their samples can filter
// (`blocks`, RG32F, vgraph.bricks.cache.block_ranges_of); a sample in a block that cannot
// contribute jumps to the first sample past the block (skipped samples add nothing, so the image
// is the same; the mode decides what "cannot contribute" means). Needs ray.glsl and
// brick_sampling.glsl (brick_scale, brick_offset).
#ifdef SKIP_EMPTY_BLOCKS
#define BLOCK 8.0
#define HALO 2.0
uniform sampler3D blocks;
uniform vec3 brick_texels;       // the brick's texture size (x, y, z) with its halo
uniform ivec3 block_count;
uniform sampler2D alpha_count;   // dvr: LUT entries 0 .. i - 1 with opacity > 0, i = 0 .. 4096

// The block of a level-0 texture coordinate (core voxel c = b * texels - HALO - 1/2, block k
// holding c in [BLOCK k - 1/2, BLOCK (k + 1) - 1/2)).
ivec3 block_of(vec3 t) {
    vec3 b = (t * brick_scale + brick_offset) * brick_texels;
    return clamp(ivec3(floor((b - HALO) / BLOCK)), ivec3(0), block_count - 1);
}

vec2 block_range(ivec3 k) {
    return texelFetch(blocks, k, 0).rg;
}

// dvr: whether the LUT has no opacity over the range (the RayCaster's rule, empty_space.py:
// the entries widened by one on each side for the filter's rounding).
bool transparent(vec2 range) {
    int lo = clamp(int(floor(clamp(range.x, 0.0, 1.0) * 4095.0)) - 1, 0, 4095);
    int hi = clamp(int(ceil(clamp(range.y, 0.0, 1.0) * 4095.0)) + 1, 0, 4095);
    return texelFetch(alpha_count, ivec2(hi + 1, 0), 0).r - texelFetch(alpha_count, ivec2(lo, 0), 0).r < 0.5;
}

// The sample index to continue from, minus one (the loop's ++i follows): the first sample at or
// past the ray's exit from block k, less 1e-3 of a step (a sample that close to the exit is still
// within half a voxel of the block, whose range covers it).
int last_in_block(Ray ray, ivec3 k, int i) {
    vec3 start = (ray.start * brick_scale + brick_offset) * brick_texels;
    vec3 step = ray.step * brick_scale * brick_texels;
    vec3 lo = vec3(k) * BLOCK + HALO;
    vec3 hi = lo + BLOCK;
    float leave = 1e30;
    for (int a = 0; a < 3; ++a) {
        if (step[a] != 0.0) {
            leave = min(leave, max((lo[a] - start[a]) / step[a], (hi[a] - start[a]) / step[a]));
        }
    }
    return max(i, int(ceil(leave - 1e-3)) - 1);
}
#define SKIP_BLOCK_IF(ray, t, i, condition) { ivec3 k = block_of(t); vec2 range = block_range(k); if (condition) { i = last_in_block(ray, k, i); continue; } }
// The same for a loop whose next index is `next` (composite_dvr.glsl): it goes on at the first
// sample past the block, whatever the brick's lattice.
#define SKIP_BLOCK_TO(ray, t, i, next, condition) { ivec3 k = block_of(t); vec2 range = block_range(k); if (condition) { next = last_in_block(ray, k, i) + 1; continue; } }
#else
#define SKIP_BLOCK_IF(ray, t, i, condition)
#define SKIP_BLOCK_TO(ray, t, i, next, condition)
#endif
