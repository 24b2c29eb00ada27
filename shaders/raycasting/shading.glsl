// Blinn-Phong shading (Inacio 2009 ch. 4.3) with the gradient as normal, two-sided, white light:
// rgb' = clamp(ambient * rgb + diffuse * max(n.L, 0) * rgb + specular * max(n.H, 0)^shininess)
// with n turned towards the viewer. LIGHT_HEADLIGHT: L = V = H (the CPU reference's model); else
// L = light_direction (world, unit, towards the light) and H = normalize(L + V). Where the gradient
// is too small to give a direction (|g| * min spacing <= 1e-6) the colour stays unshaded.
#ifdef SHADING_BLINN_PHONG
uniform float ambient;
uniform float diffuse;
uniform float specular;
uniform float shininess;
uniform float gradient_epsilon;  // 1e-6 / min(spacing)
#ifndef LIGHT_HEADLIGHT
uniform vec3 light_direction;
#endif

vec3 shade(vec3 rgb, vec3 g, vec3 view) {
    float len = length(g);
    if (len <= gradient_epsilon) {
        return rgb;
    }
    vec3 n = g / len;
#ifdef LIGHT_HEADLIGHT
    float lambert = abs(dot(n, view));
    float highlight = lambert;
#else
    n = dot(n, view) < 0.0 ? -n : n;
    float lambert = max(dot(n, light_direction), 0.0);
    vec3 halfway = light_direction + view;
    float highlight = lambert > 0.0 && dot(halfway, halfway) > 0.0
                    ? max(dot(n, normalize(halfway)), 0.0) : 0.0;
#endif
    float gloss = highlight > 0.0 ? pow(highlight, shininess) : 0.0;
    return clamp((ambient + diffuse * lambert) * rgb + specular * gloss, 0.0, 1.0);
}
#endif
