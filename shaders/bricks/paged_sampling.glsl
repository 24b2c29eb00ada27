// PagedSampling (issue #33, item 1; vgraph.bricks.paged_sampling): the volume sampled in one pass
// through a page table and a brick atlas. Same names as raycasting/volume_sampling.glsl
// (raw_sample, intensity, volume, intensity_scale/offset), so the RayCaster's compositing,
// gradients and shading work unchanged; march.glsl's PAGED_SAMPLING hook calls paged_skipped() to
// jump over cells that add nothing.
//
// A sample at level-0 texture coordinate t finds its cell by walking the page table
// (vgraph.bricks.page_table) from the top level down: through REFINE cells, remembering the last
// RESIDENT one, until a cell without REFINE: EMPTY (nothing here: skipped, or its value r), RESIDENT
// (drawn from its atlas slot) or MISSING (drawn from the last resident ancestor, a coarser level;
// nothing without one). The cell found is kept (`page`): the next samples reuse it while they lie
// in its box, so a walk happens once per cell a ray enters, not per sample. Reads of a drawn cell
// (trilinear, gradients) stay in its slot while they lie within one voxel of its level outside the
// box: the slot's apron of 2 voxels holds what they filter, so values equal the whole volume's.
#define PAGE_RESIDENT 1
#define PAGE_REFINE 2
#define PAGE_EMPTY 4
#define PAGE_FAR 1e6  // the volume's outer faces: samples on or a rounding past them have an owner

uniform sampler3D volume;        // the atlas
uniform sampler3D page_table;    // RGBA32F: rgb = texel offset or value, a = flags
uniform float intensity_scale;   // normalised intensity = raw * scale + offset
uniform float intensity_offset;
uniform vec3 atlas_texels;                   // the atlas's size (x, y, z)
uniform ivec3 page_grid[PAGE_LEVELS];        // cells per axis of each level
uniform int page_z[PAGE_LEVELS];             // the level's first z in the page table
uniform vec3 cell_scale[PAGE_LEVELS];        // t -> cell coordinates: level-0 voxels / cell span
uniform vec3 level_scale[PAGE_LEVELS];       // t -> the level's voxel coordinate u = t * scale + offset
uniform vec3 level_offset[PAGE_LEVELS];

struct Page {
    vec3 lo;        // the cell's box in t (half-open; the volume's outer faces pushed to PAGE_FAR)
    vec3 hi;
    vec3 read_lo;   // where reads may use its slot: the box and one voxel of its level around it
    vec3 read_hi;
    bool drawn;     // false: nothing is drawn here (EMPTY, or MISSING without a resident ancestor)
    vec3 scale;     // t -> atlas coordinates, when drawn
    vec3 offset;
    float value;    // the raw value of a cell not drawn
};

Page page = Page(vec3(1.0), vec3(0.0), vec3(1.0), vec3(0.0), false, vec3(0.0), vec3(0.0), 0.0);

bool in_box(vec3 t, vec3 lo, vec3 hi) {
    return all(greaterThanEqual(t, lo)) && all(lessThan(t, hi));
}

// Walk the page table for the cell holding t (see the top).
void find_page(vec3 t) {
    int drawn_level = -1;
    vec3 drawn_offset = vec3(0.0);
    page.drawn = false;
    page.value = -intensity_offset / intensity_scale;  // normalised 0: nothing in mip and iso
    for (int level = PAGE_LEVELS - 1; level >= 0; --level) {
        ivec3 last = page_grid[level] - 1;
        ivec3 cell = clamp(ivec3(floor(t * cell_scale[level])), ivec3(0), last);
        vec4 entry = texelFetch(page_table, ivec3(cell.xy, cell.z + page_z[level]), 0);
        int flags = int(entry.a + 0.5);
        page.lo = mix(vec3(cell) / cell_scale[level], vec3(-PAGE_FAR), equal(cell, ivec3(0)));
        page.hi = mix(vec3(cell + 1) / cell_scale[level], vec3(PAGE_FAR), equal(cell, last));
        if ((flags & PAGE_RESIDENT) != 0) {
            drawn_level = level;
            drawn_offset = entry.rgb;
        }
        if ((flags & PAGE_REFINE) != 0) {
            continue;
        }
        if ((flags & PAGE_EMPTY) != 0) {
            page.value = (entry.r - intensity_offset) / intensity_scale;
            drawn_level = -1;
        }
        break;
    }
    page.read_lo = page.lo;
    page.read_hi = page.hi;
    if (drawn_level >= 0) {
        page.drawn = true;
        page.scale = level_scale[drawn_level] / atlas_texels;
        page.offset = (level_offset[drawn_level] + drawn_offset) / atlas_texels;
        vec3 voxel = 1.0 / level_scale[drawn_level];  // one voxel of the level, in t
        page.read_lo -= voxel;
        page.read_hi += voxel;
    }
}

float raw_sample(vec3 t) {
    if (!in_box(t, page.read_lo, page.read_hi)) {
        find_page(t);
    }
    return page.drawn ? textureLod(volume, t * page.scale + page.offset, 0.0).r : page.value;
}

float intensity(vec3 t) {
    return raw_sample(t) * intensity_scale + intensity_offset;
}

// Where sample i lies in a cell that is not drawn, move i to the first sample past the cell's box
// and return true (march.glsl's PAGED_SAMPLING hook jumps until this returns false).
bool paged_skipped(inout int i, Ray ray) {
    vec3 t = sample_point(ray, float(i));
    if (!in_box(t, page.lo, page.hi)) {
        find_page(t);
    }
    if (page.drawn) {
        return false;
    }
    // Per axis, the sample index where the ray leaves the box (the face ahead of it).
    vec3 face = mix(page.lo, page.hi, step(vec3(0.0), ray.step));
    vec3 ahead = vec3(ray.step.x != 0.0 ? (face.x - ray.start.x) / ray.step.x : 1e30,
                      ray.step.y != 0.0 ? (face.y - ray.start.y) / ray.step.y : 1e30,
                      ray.step.z != 0.0 ? (face.z - ray.start.z) / ray.step.z : 1e30);
    float leave = min(min(ahead.x, ahead.y), ahead.z);
    i = max(i + 1, int(min(ceil(leave), float(ray.samples))));
    return true;
}
