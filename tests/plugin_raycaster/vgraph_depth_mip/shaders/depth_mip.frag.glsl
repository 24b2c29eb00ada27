#version 330
// Depth-coloured MIP: the brightest sample along the pixel's ray, coloured by where it lies
// between the ray's entry (near_colour) and exit (far_colour). Its components bring the rest:
// pixel_ray() and the Ray (EntryExit, CameraRays), intensity() (VolumeSampling), the step
// (Sampling) and over_background() (Background).
uniform vec3 near_colour;
uniform vec3 far_colour;

out vec4 color;

void main() {
    Ray ray;
    if (!pixel_ray(ray)) {
        color = background;
        return;
    }
    float brightest = 0.0;
    float where = 0.0;  // 0 at the entry, 1 at the exit
    for (int i = 0; i < ray.samples; ++i) {
        float value = clamp(intensity(sample_point(ray, float(i))), 0.0, 1.0);
        if (value > brightest) {
            brightest = value;
            where = float(i) / max(ray.steps, 1.0);
        }
    }
    color = over_background(vec4(brightest * mix(near_colour, far_colour, where), brightest));
}
