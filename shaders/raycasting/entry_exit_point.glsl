// The points an EntryExitPoints fragment stores, shared by the face and plane-cap passes.
//
// The pixel's ray is the one of Camera.rays: origin on the near plane, direction through the
// pixel centre (not normalised: its component along the view direction is 1, so the far plane is
// at ray parameter far - near). Its intersection with the box of the voxel centres is computed
// exactly by the slab test, clipped to [0, far - near] (rays that meet the box grown by
// BOX_EPSILON count as hits, as in the CPU reference): rasterised faces only say which pixels to compute, because interpolated
// attributes would inherit the rasteriser's sub-pixel snapping of the vertices (llvmpipe: 1/256
// pixel, errors of ~1e-3 voxel and ragged edges).
//
// Stored, both in one pass: rgb = texture coordinates of the entry point and of the exit point,
// clamped to the box of the voxel centres (with EntryExitPoints' volume2..volume4 connected: to
// the union of the volumes' boxes, in the first volume's texture space, so they may leave [0, 1]),
// alpha = 1. Rays that miss are discarded (the images are cleared to 0). Entry points may be
// jittered: moved towards the exit point by a per-pixel pseudo-random fraction of `jitter` world
// units, never past it.
//
// CLIP_PLANES = n (vgraph.clipping; only defined for n > 0, so scenes without planes compile the
// same program as before): the interval is also cut to the kept side of n planes, dot(p, normal)
// >= offset. A ray whose front face lies in the removed part now starts on the plane: the cut
// shows the inside (capping), for every ray caster, as they march from entry to exit point. A
// crop box needs no code here: EntryExitPoints narrows box_min/box_max (and the hit box) to it.
// The pixel's ray start: pixel_ndc() in the whole picture (a tile's too: geometry.pixel_rays),
// near_point(ndc) on the near plane; its direction ray_direction(ndc).
#include "raycasting/pixel_direction.glsl"
uniform float near_to_far;      // far - near

uniform vec3 box_min;      // world: the box of the voxel centres (or the union of several)
uniform vec3 box_max;
uniform vec3 hit_box_min;  // the same grown by BOX_EPSILON: rays meeting it count as hits
uniform vec3 hit_box_max;
uniform vec3 world_to_texture_scale;  // t = p * scale + offset
uniform vec3 world_to_texture_offset;
uniform vec3 texture_box_min;  // 0.5 / dims (several volumes: the union box's corner)
uniform vec3 texture_box_max;  // 1 - 0.5 / dims

#ifdef CLIP_PLANES
uniform vec3 clip_normals[CLIP_PLANES];  // world, unit
uniform float clip_offsets[CLIP_PLANES];

// The part of [interval.x, interval.y] on the kept side of every plane (empty: y < x).
vec2 clip_interval(vec3 origin, vec3 direction, vec2 interval) {
    for (int i = 0; i < CLIP_PLANES; ++i) {
        float height = dot(origin, clip_normals[i]) - clip_offsets[i];  // >= 0: kept
        float rate = dot(direction, clip_normals[i]);
        if (rate > 0.0) {
            interval.x = max(interval.x, -height / rate);
        } else if (rate < 0.0) {
            interval.y = min(interval.y, -height / rate);
        } else if (height < 0.0) {
            interval.y = -1.0;  // parallel to the plane, on the removed side
        }
    }
    return interval;
}
#endif

uniform float jitter;                 // world units; 0 turns jitter off
uniform vec3 texture_to_world_scale;  // dims * spacing

// Interleaved gradient noise (Jimenez 2014): a fixed pattern in [0, 1), so images are reproducible.
float pixel_noise(vec2 pixel) {
    return fract(52.9829189 * fract(dot(pixel, vec2(0.06711056, 0.00583715))));
}

// The whole picture's pixel: a tile's pixels get the same numbers, bit for bit.
vec2 picture_pixel() {
    return gl_FragCoord.xy + pixel_offset;
}

// The ray parameters [enter, leave] of the part of the ray inside [lo, hi] and in [0, far - near].
vec2 slab_interval(vec3 origin, vec3 inverse, vec3 lo, vec3 hi) {
    vec3 t0 = (lo - origin) * inverse;
    vec3 t1 = (hi - origin) * inverse;
    vec3 near_t = min(t0, t1);
    vec3 far_t = max(t0, t1);
    return vec2(max(max(max(near_t.x, near_t.y), near_t.z), 0.0),
                min(min(min(far_t.x, far_t.y), far_t.z), near_to_far));
}

// The texture coordinates of the point at ray parameter s (clamped to the box).
vec3 texture_point(vec3 origin, vec3 direction, float s) {
    vec3 t = (origin + s * direction) * world_to_texture_scale + world_to_texture_offset;
    return clamp(t, texture_box_min, texture_box_max);
}

void box_points(out vec4 entry, out vec4 exit) {
    vec2 ndc = pixel_ndc();
    vec3 origin = near_point(ndc);
    vec3 direction = ray_direction(ndc);
    vec3 inverse = inverse_direction(direction);
    // Hit or miss by the grown box; the points from the box itself (the grown box's faces lie
    // off the voxel-centre box by BOX_EPSILON, which oblique rays would carry sideways).
    vec2 grown = slab_interval(origin, inverse, hit_box_min, hit_box_max);
    if (grown.y < grown.x) {
        discard;
    }
    vec2 exact = slab_interval(origin, inverse, box_min, box_max);
    vec2 interval = exact.y < exact.x ? grown : exact;  // a grazing ray: only the grown box
#ifdef CLIP_PLANES
    interval = clip_interval(origin, direction, interval);
    if (interval.y < interval.x) {
        discard;  // the ray's part in the box is all on the removed side
    }
#endif
    vec3 t = texture_point(origin, direction, interval.x);
    vec3 u = texture_point(origin, direction, interval.y);
    if (jitter > 0.0) {
        vec3 along = u - t;
        float len = length(along * texture_to_world_scale);
        if (len > 0.0) {
            t += along * (min(jitter * pixel_noise(floor(picture_pixel())), len) / len);
        }
    }
    entry = vec4(t, 1.0);
    exit = vec4(u, 1.0);
}
