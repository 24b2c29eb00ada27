// Principal curvatures of the level set through a point from the gradient g and Hessian of the
// field (Kindlmann et al. 2003; Cabral 2010 listing 5.1 and sec. 3.6), the GLSL twin of
// vgraph.numerics.curvature.kindlmann:
//   n = -g / |g| (outward: the interior is brighter), P = I - n n^T, G = -P H P / |g|,
//   T = trace G, F = |G|_Frobenius, k1,2 = (T +- sqrt(2 F^2 - T^2)) / 2, K = k1 k2, H = (k1 + k2) / 2.
// (The seed's listing drops the minus sign of G; with it a sphere has k1 = k2 = +1/r.)
// Guards, so that nothing non-finite ever comes out:
// - |g| <= min_gradient (or not finite): no surface direction, curvature undefined;
// - 2 F^2 - T^2 < 0 by rounding at umbilics: clamped to 0 (still defined);
// - a result that overflowed: undefined.
// |g| is computed from g scaled by its largest component, so huge or tiny gradients neither
// overflow nor underflow. Comparisons are written so that NaN fails them (no isnan(), which
// fast-math compilers may drop).

// Returns true where the curvature is defined; k = (k1, k2, K, H) there, else 0.
bool kindlmann_curvature(vec3 g, mat3 hessian, float min_gradient, out vec4 k) {
    k = vec4(0.0);
    float largest = max(max(abs(g.x), abs(g.y)), abs(g.z));
    if (!(largest > 0.0 && largest < 3.0e38)) {
        return false;
    }
    vec3 direction = g / largest;
    float length_scaled = length(direction);
    float gradient_length = largest * length_scaled;
    if (!(gradient_length > min_gradient && gradient_length < 3.0e38)) {
        return false;
    }
    vec3 n = -direction / length_scaled;
    mat3 projector = mat3(1.0) - outerProduct(n, n);
    mat3 symmetric = 0.5 * (hessian + transpose(hessian));
    mat3 geometry = -(projector * symmetric * projector) / gradient_length;
    float trace = geometry[0][0] + geometry[1][1] + geometry[2][2];
    float frobenius_sq = dot(geometry[0], geometry[0]) + dot(geometry[1], geometry[1])
                       + dot(geometry[2], geometry[2]);
    float root = sqrt(max(2.0 * frobenius_sq - trace * trace, 0.0));
    float k1 = 0.5 * (trace + root);
    float k2 = 0.5 * (trace - root);
    vec4 result = vec4(k1, k2, k1 * k2, 0.5 * (k1 + k2));
    if (!all(lessThan(abs(result), vec4(3.0e38)))) {
        return false;
    }
    k = result;
    return true;
}
