// Porter & Duff's (1984) "over" of premultiplied RGBA: front + (1 - front alpha) back, the ray
// casters' front-to-back rule. ImageCompositor (mode over), Background and TextOverlay composite
// with it.
vec4 over(vec4 front, vec4 back) {
    return front + (1.0 - front.a) * back;
}
