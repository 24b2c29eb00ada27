// The samples of a ray that one brick owns (BrickedRayCaster). Sample i lies at
// sample_point(ray, i) (ray.glsl: the RayCaster's lattice from the volume's entry point); the brick
// owns those whose point p satisfies owner_lo <= p < owner_hi on every axis (half-open, the outer
// faces of the volume pushed far out), so each sample is taken in exactly one brick. The slab
// intersection gives the candidate index range, widened by one sample on each side against
// rounding; owns() decides each sample with the same float expression in every brick.
// A brick of a coarse level samples on its own lattice (level_stride > 1: the level's step is
// level_stride steps of level 0, 2^L where every axis halves): it takes its first owned sample and
// then every sample of index k * level_stride it owns, each standing for the level-0 samples up to
// the next one it takes (its `weight`, at most level_stride; the last stops at the brick's last owned
// sample), its opacity corrected for that many steps (stepped_opacity). The brick's samples thus
// stand for exactly the level-0 samples it owns: no gap and no overlap at a seam between levels.
// Needs ray.glsl and transfer_function.glsl.
uniform vec3 owner_lo;
uniform vec3 owner_hi;
uniform int level_stride;  // 1 at level 0

struct Span {
    int first;  // candidate samples first .. last (may be empty: first > last)
    int last;
};

bool owns(vec3 p) {
    return all(greaterThanEqual(p, owner_lo)) && all(lessThan(p, owner_hi));
}

Span owned_span(Ray ray) {
    float enter = 0.0;
    float leave = float(ray.samples - 1);
    for (int a = 0; a < 3; ++a) {
        if (ray.step[a] != 0.0) {
            float s0 = (owner_lo[a] - ray.start[a]) / ray.step[a];
            float s1 = (owner_hi[a] - ray.start[a]) / ray.step[a];
            enter = max(enter, min(s0, s1));
            leave = min(leave, max(s0, s1));
        } else if (ray.start[a] < owner_lo[a] || ray.start[a] >= owner_hi[a]) {
            return Span(1, 0);
        }
    }
    if (enter > leave + 1.0) {
        return Span(1, 0);
    }
    return Span(max(int(floor(enter)) - 1, 0), min(int(ceil(leave)) + 1, ray.samples - 1));
}

// The owned samples of a coarse brick, first .. last (the owned samples of a ray in a box are one
// run: sample_point is monotone in i); first > last where it owns none.
Span owned_run(Ray ray, Span span) {
    int first = span.first;
    while (first <= span.last && !owns(sample_point(ray, float(first)))) {
        ++first;
    }
    int last = span.last;
    while (last >= first && !owns(sample_point(ray, float(last)))) {
        --last;
    }
    return Span(first, last);
}

// The sample after i that this brick takes (level 0: i + 1), at most last + 1.
int next_taken(int i, int last) {
    return min((i / level_stride + 1) * level_stride, last + 1);
}

#include "bricks/stepped_opacity.glsl"  // stepped_opacity()
