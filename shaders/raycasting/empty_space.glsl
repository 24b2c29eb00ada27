// Empty-space skipping (SKIP_EMPTY_SPACE): a coarse grid of blocks of voxels, one value per block in
// the R32F texture `blocks` (vgraph.gl.volume_rendering: which voxels a block covers). What the value
// means depends on the compositing mode:
// - dvr, first_hit, iso: 0 = the block may contribute (some intensity in it has TF opacity > 0, or
//   reaches the iso level); k >= 1 = every block within Chebyshev distance k - 1 is empty, so the
//   ray may jump to where it leaves that cube of (2k - 1)^3 blocks;
// - mip: the block's maximum normalised intensity (a block not above the current maximum is skipped).
// Skipped samples keep their positions start + i * step, so skipping changes no image, only work.
// The grid and its walk (BlockWalk, block_value) also serve the single-pass bricked ray caster's
// mip (PAGED_MIP_WALK: a grid of block maxima over the frame's bricks, bricks/paged_sampling.glsl),
// its dvr (PAGED_WALK: a grid of skip radii over the frame's bricks, march.glsl) and its iso
// (PAGED_ISO_GRID: skip radii whose texels also say where to read, march.glsl).
#if defined(SKIP_EMPTY_SPACE) || defined(PAGED_MIP_WALK) || defined(PAGED_WALK) || defined(PAGED_ISO_GRID)
uniform sampler3D blocks;
uniform vec3 block_scale;   // texture -> block coordinates: q = t * scale + offset
uniform vec3 block_offset;
uniform ivec3 block_count;

struct BlockWalk {
    vec3 start;         // block coordinates of sample 0
    vec3 step;
    vec3 steps_per_unit;  // 1 / step per axis (1e30 where the ray does not move along the axis)
};

BlockWalk block_walk(Ray ray) {
    BlockWalk walk;
    walk.start = ray.start * block_scale + block_offset;
    walk.step = ray.step * block_scale;
    walk.steps_per_unit = vec3(walk.step.x != 0.0 ? 1.0 / walk.step.x : 1e30,
                               walk.step.y != 0.0 ? 1.0 / walk.step.y : 1e30,
                               walk.step.z != 0.0 ? 1.0 / walk.step.z : 1e30);
    return walk;
}

float block_value(ivec3 block) {
    return texelFetch(blocks, block, 0).r;
}
#endif

#if defined(SKIP_EMPTY_SPACE) || defined(PAGED_WALK) || defined(PAGED_ISO_GRID)
ivec3 block_of(BlockWalk walk, int i) {
    return clamp(ivec3(walk.start + float(i) * walk.step), ivec3(0), block_count - 1);
}

// The first sample index after sample i outside the cube of blocks within Chebyshev distance
// radius - 1 of `block` (at least i + 1).
int next_sample_outside(BlockWalk walk, int i, ivec3 block, float radius, int samples) {
    vec3 q = walk.start + float(i) * walk.step;
    // The face the ray leaves through: block + radius going up, block + 1 - radius going down.
    vec3 bound = vec3(block) + mix(vec3(1.0 - radius), vec3(radius), step(vec3(0.0), walk.step));
    vec3 ahead = (bound - q) * walk.steps_per_unit;
    float steps = clamp(min(min(ahead.x, ahead.y), ahead.z), 0.0, float(samples));
    return i + 1 + int(steps);
}

// Where sample i lies in an empty region, move i past it and return true (march.glsl jumps until
// this returns false); otherwise leave i and return false.
bool skipped_empty_region(BlockWalk walk, inout int i, int samples) {
    ivec3 block = block_of(walk, i);
    float radius = block_value(block);
    if (radius <= 0.0) {
        return false;
    }
    i = next_sample_outside(walk, i, block, radius, samples);
    return true;
}
#endif
