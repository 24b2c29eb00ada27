// The samples of a ray that one brick owns (BrickedRayCaster). Sample i lies at
// sample_point(ray, i) (ray.glsl: the RayCaster's lattice from the volume's entry point); the brick
// owns those whose point p satisfies owner_lo <= p < owner_hi on every axis (half-open, the outer
// faces of the volume pushed far out), so each sample is taken in exactly one brick. The slab
// intersection gives the candidate index range, widened by one sample on each side against
// rounding; owns() decides each sample with the same float expression in every brick.
// Needs ray.glsl.
uniform vec3 owner_lo;
uniform vec3 owner_hi;

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
