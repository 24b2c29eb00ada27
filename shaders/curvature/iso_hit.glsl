// The hit search of the curvature ray casters: the first point along the ray where the field
// crosses `raw_level` (the normalised `level` in raw texture units), in either direction: a ray
// that starts inside the object (value >= level at its entry point, e.g. where the box cuts the
// object) shows the surface where it leaves the object; the box's cut face is not a surface.
//
// March: march_value() at samples i = 0 .. samples - 1 (ray.glsl), then the exit point; the first
// pair of consecutive points on different sides ("inside" = value >= level) brackets the hit.
// With SKIP_EMPTY_SPACE, regions of blocks that cannot hold a crossing are jumped over
// (empty_space.glsl) and the march resumes one sample before the landing point (a sample of the
// skipped region: same side), so every evaluated sample has its predecessor.
//
// Refinement, by the Illinois variant of regula falsi on a fraction s of the bracket from its first
// point (a texture-space origin plus s * span, which keeps more digits than a sample index would):
// first on march_value() (cheap: 8 fetches per step for the spline) until a point is estimated to
// be within HIT_COARSE_WIDTH of the span from the root (|value| over the bracket's secant slope),
// then on field_value() from a bracket of +-2 HIT_COARSE_WIDTH around that estimate (where the
// field is linear to ~1e-8, so a secant step or two suffice) until within HIT_FINE_WIDTH or the
// bracket is one float wide. Should field_value() not bracket the root there, the fine stage
// starts again from the coarse bracket, then from the whole one. The end with the smaller
// |value - level| is the hit: on the reconstructed surface to float precision.
//
// Written for SIMD rasterisers such as llvmpipe, which pay for the body of every `if` that any lane
// of a group takes but leave a loop when all lanes are done: each costly evaluation sits in a loop
// body that evaluates once per iteration; branches only choose points.
#define HIT_REFINEMENT_STEPS 30
#define HIT_COARSE_WIDTH 1e-4
// Below the float32 resolution of texture coordinates (6e-8 of the volume = 4e-6 voxel at 64^3).
#define HIT_FINE_WIDTH 1e-7
uniform float raw_level;

struct Hit {
    bool found;
    vec3 point;  // texture coordinates of the hit
    int taken;   // samples evaluated by the march (the depth output's counter)
};

// A bracket [a, b] of the fraction s with values va, vb (minus the level) on different sides;
// wa, wb are the secant's weights (halved when one end is kept twice in a row: Illinois).
struct Bracket {
    float a, b, va, vb, wa, wb;
    int kept;  // 1: a was kept by the last step, 2: b was
};

Bracket make_bracket(float a, float b, float va, float vb) {
    return Bracket(a, b, va, vb, va, vb, 0);
}

bool on_one_side(Bracket bracket) {
    return (bracket.va >= 0.0) == (bracket.vb >= 0.0);
}

// The next point to evaluate, or -1 when the bracket is one float wide.
float bracket_next(Bracket bracket) {
    float a = bracket.a, b = bracket.b;
    float m = a + (b - a) * (bracket.wa / (bracket.wa - bracket.wb));
    if (!(m > a && m < b)) {
        m = 0.5 * (a + b);
    }
    return m > a && m < b ? m : -1.0;
}

void bracket_update(inout Bracket bracket, float m, float vm) {
    if ((vm >= 0.0) == (bracket.vb >= 0.0)) {
        bracket.b = m; bracket.vb = vm; bracket.wb = vm;
        if (bracket.kept == 1) bracket.wa *= 0.5;
        bracket.kept = 1;
    } else {
        bracket.a = m; bracket.va = vm; bracket.wa = vm;
        if (bracket.kept == 2) bracket.wb *= 0.5;
        bracket.kept = 2;
    }
}

// Whether a point of value vm inside the bracket is within `width` (a fraction of the span) of the
// root, estimated with the bracket's secant slope (vm == 0 is).
bool close_to_root(Bracket bracket, float vm, float width) {
    return abs(vm) * (bracket.b - bracket.a) <= width * abs(bracket.vb - bracket.va);
}

float closer_end(Bracket bracket) {
    return abs(bracket.va) <= abs(bracket.vb) ? bracket.a : bracket.b;
}

// The root of value(origin + s span) = raw_level for s in [0, 1], given the march values v0, v1
// (minus the level) at s = 0 and 1, on different sides.
vec3 refine_hit(vec3 origin, vec3 span, float v0, float v1) {
    Bracket coarse = make_bracket(0.0, 1.0, v0, v1);
    for (int k = 0; k < HIT_REFINEMENT_STEPS; ++k) {
        float m = bracket_next(coarse);
        if (m < 0.0) break;
        float vm = march_value(origin + m * span) - raw_level;
        bool done = close_to_root(coarse, vm, HIT_COARSE_WIDTH);
        bracket_update(coarse, m, vm);
        if (done) break;
    }
    float estimate = closer_end(coarse);
    float low = max(estimate - 2.0 * HIT_COARSE_WIDTH, coarse.a);
    float high = min(estimate + 2.0 * HIT_COARSE_WIDTH, coarse.b);
    Bracket fine = make_bracket(low, high, 0.0, 0.0);
    int phase = 0;    // 0: evaluate the low end, 1: the high end, 2: refine
    int attempt = 0;  // brackets tried: the small one, the coarse one, the whole one
    float low_value = 0.0;
    for (int k = 0; k < HIT_REFINEMENT_STEPS + 6; ++k) {
        float m = phase == 0 ? low : (phase == 1 ? high : bracket_next(fine));
        if (m < 0.0) break;
        float vm = field_value(origin + m * span) - raw_level;
        if (phase == 0) {
            low_value = vm;
            phase = 1;
        } else if (phase == 1) {
            fine = make_bracket(low, high, low_value, vm);
            phase = on_one_side(fine) ? 0 : 2;
            if (phase == 0) {
                if (attempt == 2) break;  // the values disagree by rounding: the closer end
                attempt++;
                low = attempt == 1 ? coarse.a : 0.0;
                high = attempt == 1 ? coarse.b : 1.0;
            }
        } else {
            bool done = close_to_root(fine, vm, HIT_FINE_WIDTH);
            bracket_update(fine, m, vm);
            if (done) break;
        }
    }
    return origin + closer_end(fine) * span;
}

Hit find_hit(Ray ray) {
    Hit hit = Hit(false, ray.start, 0);
    vec3 origin = ray.start;
    vec3 span = ray.step;
    float previous = 0.0, value = 0.0;
    bool have_previous = false;
    bool check_skip = true;
    March cursor = start_march(ray);
    while (cursor.i < ray.samples) {
        if (check_skip && skip_empty_space(cursor, ray)) {
            cursor.i -= 1;  // resume on the last skipped sample, without checking it again
            have_previous = false;
            check_skip = false;
            continue;
        }
        check_skip = true;
        value = march_value(sample_point(ray, float(cursor.i))) - raw_level;
        hit.taken++;
        if (have_previous && (value >= 0.0) != (previous >= 0.0)) {
            hit.found = true;
            origin = sample_point(ray, float(cursor.i - 1));
            break;
        }
        previous = value;
        have_previous = true;
        ++cursor.i;
    }
    // The stretch between the last sample and the exit point (shorter than one step).
    vec3 last = sample_point(ray, float(ray.samples - 1));
    vec3 rest = ray.end - last;
    float last_value = march_value(last) - raw_level;
    float end_value = march_value(ray.end) - raw_level;
    bool in_rest = !hit.found && dot(rest, rest) > 0.0 && (end_value >= 0.0) != (last_value >= 0.0);
    if (in_rest) {
        hit.found = true;
        origin = last;
        span = rest;
        previous = last_value;
        value = end_value;
    }
    if (hit.found) {
        hit.point = refine_hit(origin, span, previous, value);
    }
    return hit;
}
