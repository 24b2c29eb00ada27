// PAGED_STRIDE (dvr in the single pass, vgraph.bricks.paged_strides): a run through a cell drawn at
// a coarse level samples that level's own lattice, as a pass per brick does (brick_span.glsl): of
// level 0's samples it takes the first one its brick owns and then every one whose index is a
// multiple of the level's stride, each standing for the samples up to the next one it takes (at
// most the stride; the last stops at the brick's last owned sample), its opacity that of so many
// level-0 steps (stepped_opacity). Samples of every level stay on level 0's lattice, so ownership
// and seams are unchanged, and a coarse cell costs a stride-th of its samples. A level-0 cell's
// stride is 1: every sample, weight 1, corrected_opacity itself.
//
// A brick owns the samples in its cell. Where a level is whole (level_strides > 0: every level-0
// cell inside each of its drawn cells is drawn from that cell's brick, as in every frame whose
// planned bricks are all in the atlas) a run is the whole drawn cell; else (a cell drawn from a
// resident ancestor in place of missing bricks, beside finer cells inside the ancestor's cell, or
// cells not drawn) runs are level-0 cells and a brick's span is cut where the cells beside it are
// drawn otherwise (stride_run): no gap and no overlap either way.
// Samples the march skips lie in empty blocks and add nothing; where a skip lands between taken
// samples the one that stands for it was skipped, so the march moves on to the next taken one
// (stride_from), as a pass per brick's block skipping does.
// Needs ray.glsl, bricks/paged_sampling.glsl's cell_box and uniforms (the opacity: compositing_dvr.glsl).
#ifdef PAGED_STRIDE
// frame steps per sample of each level's lattice (1: level 0), negative where the level is not whole
// (PAGED_STRIDE_WHOLE: every level is, as in each frame whose planned bricks are all in the atlas)
uniform int level_strides[PAGE_LEVELS];

int stride_step = 1;   // the current run's level's stride
int stride_first = 0;  // the first sample its brick owns
int stride_end = 0;    // the first sample past the brick's last owned one

// The samples [first, end) of the ray inside the half-open box [lo, hi).
ivec2 box_samples(vec3 lo, vec3 hi, Ray ray) {
    float first = 0.0;
    float end = float(ray.samples);
    for (int a = 0; a < 3; ++a) {
        if (ray.step[a] > 0.0) {
            first = max(first, ceil((lo[a] - ray.start[a]) / ray.step[a]));
            end = min(end, ceil((hi[a] - ray.start[a]) / ray.step[a]));
        } else if (ray.step[a] < 0.0) {
            first = max(first, floor((hi[a] - ray.start[a]) / ray.step[a]) + 1.0);
            end = min(end, floor((lo[a] - ray.start[a]) / ray.step[a]) + 1.0);
        }
    }
    return ivec2(clamp(vec2(first, end), 0.0, float(ray.samples)));  // (far faces: no int overflow)
}

// The level of the box that a run of a drawn cell of `level` spans (paged_run): the cell's own
// where the level is whole, else its level-0 cell.
int stride_box_level(int level) {
#ifdef PAGED_STRIDE_WHOLE
    return level;
#else
    return level_strides[level] > 0 ? level : 0;
#endif
}

// Whether sample i lies in a cell drawn otherwise than from the brick of leaf entry `entry`.
bool stride_other(int i, vec4 entry, Ray ray) {
    return any(notEqual(leaf_entry(sample_point(ray, float(i))), entry));
}

// paged_run's hook: a run of the drawn cell of sample i (at t, its leaf entry `entry`) starts, up
// to run_end.
void stride_run(vec3 t, vec4 entry, int i, int run_end, Ray ray) {
    int level = int(entry.a + 0.5) - 1;
    stride_step = abs(level_strides[level]);
    vec3 lo, hi;
    cell_box(t, cell_scale[level], page_grid[level], lo, hi);
    ivec2 span = box_samples(lo, hi, ray);
    stride_first = min(span.x, i);  // (a rounding may put i before the box's first)
    stride_end = max(span.y, run_end);
#ifndef PAGED_STRIDE_WHOLE  // (every level whole: compiled out, as llvmpipe runs an if's body for all lanes)
    if (level_strides[level] > 0) {
        return;  // a whole level: the run is its cell, the brick's span
    }
    // With missing bricks a cell drawn from a resident ancestor may border, inside the ancestor's
    // cell, a finer cell drawn from its own brick: the ancestor's span stops there. A sample's
    // weight reaches up to stride - 1 samples ahead, across a level-0 cell's face (and past a cell
    // the ray only clips), so this level-0 cell's first sample is taken where the sample that would
    // stand for it, the samples up to the cell or its reach are another brick's; and its weight
    // ends at the cell's end where the next sample or the reach of its last is. The same samples
    // decide both sides of a face. (Look-ups only in frames still refining.)
    cell_box(t, cell_scale[0], page_grid[0], lo, hi);
    ivec2 cell = box_samples(lo, hi, ray);
    cell = ivec2(min(cell.x, i), max(cell.y, run_end));
    if (stride_first < cell.x && cell.x % stride_step != 0) {
        int stand = max(cell.x / stride_step * stride_step, stride_first);
        int reach = min((cell.x / stride_step + 1) * stride_step, stride_end) - 1;
        if (stride_other(stand, entry, ray) || stride_other(cell.x - 1, entry, ray) || stride_other(reach, entry, ray)) {
            stride_first = cell.x;
        }
    }
    int reach = min(((cell.y - 1) / stride_step + 1) * stride_step, stride_end) - 1;
    if (cell.y < stride_end && (stride_other(cell.y, entry, ray) || stride_other(reach, entry, ray))) {
        stride_end = cell.y;
    }
#endif
}

// The first sample at or after i (in the current run's brick) that the brick takes.
int stride_from(int i) {
    return i == stride_first ? i : (i + stride_step - 1) / stride_step * stride_step;
}

// The sample the brick takes after the taken sample i: sample i stands for the samples up to it.
int stride_next(int i) {
    return min((i / stride_step + 1) * stride_step, max(stride_end, i + 1));
}
#endif
