// A ray of the RayCaster: from its entry to its exit point (texture coordinates, read from the
// EntryExitPoints images), with samples every `step_length` world units (Inacio 2009 ch. 4.1.2:
// sampling in world space, so anisotropic spacing is sampled correctly). Sample i is at
// start + i * step, i = 0 .. samples - 1, with samples = floor(length / step_length + 1e-3) + 1:
// the first sample lies on the entry point and, when the length is a whole number of steps, the
// last one on the exit point (the CPU reference's rule). No matrix per sample: one multiply-add.
uniform vec3 texture_to_world_scale;  // dims * spacing: texture-space vectors -> world vectors
uniform float step_length;            // world units: min(spacing) / sampling_rate
uniform vec3 view_forward;            // world, unit: the direction of rays of zero length

struct Ray {
    vec3 start;      // texture coordinates of sample 0 (the entry point)
    vec3 end;        // texture coordinates of the exit point
    vec3 step;       // texture-space offset between samples
    int samples;
    float steps;     // the ray's length in steps (samples - 1 <= steps < samples, up to 1e-3)
    vec3 direction;  // world space, unit
};

Ray make_ray(vec3 entry_point, vec3 exit_point) {
    vec3 along = exit_point - entry_point;
    vec3 along_world = along * texture_to_world_scale;
    float len = length(along_world);
    Ray ray;
    ray.start = entry_point;
    ray.end = exit_point;
    ray.steps = len / step_length;
    ray.samples = int(floor(ray.steps + 1e-3)) + 1;
    ray.step = len > 0.0 ? along * (step_length / len) : vec3(0.0);
    ray.direction = len > 0.0 ? along_world / len : view_forward;
    return ray;
}

vec3 sample_point(Ray ray, float i) {
    return ray.start + i * ray.step;
}

// What a compositing mode returns: premultiplied colour and coverage (before the background), the
// (fractional) sample index that gives the depth output (-1: none), and the samples evaluated.
struct Result {
    vec4 color;
    float depth_sample;
    int taken;
};

Result empty_result() {
    return Result(vec4(0.0), -1.0, 0);
}
