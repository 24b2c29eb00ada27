// The straight (not premultiplied) colour of a premultiplied RGBA texel: rgb / a where alpha is
// positive; where alpha is 0 the stored rgb as it is (0 for a transparent background, the light of
// an additive overlay otherwise). premultiplied() undoes it with the same alpha.
vec3 straight_color(vec4 texel) {
    return texel.a > 0.0 ? texel.rgb / texel.a : texel.rgb;
}

vec4 premultiplied(vec3 straight, float alpha) {
    return vec4(alpha > 0.0 ? straight * alpha : straight, alpha);
}
