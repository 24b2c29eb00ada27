"""Exact CPU reference for rendering tetrahedral meshes (numpy). The GL mesh renderers are tested
against it; docs/explanations/tetrahedra.md ("The exact CPU reference") explains the model.

Model, in this order (the segment integral of rules 3 and 4 is vgraph.numerics.segment_integral;
``segment_integral`` and ``MAX_OPACITY`` import from here as well):

1. Rays: ``Camera.rays(W, H)`` of the camera resolved against the mesh's bounds
   (``camera.resolved(*mesh.bounds, W / H)``) - one per pixel centre, row 0 at the top, origin on
   the near plane (t = 0), unit direction, t in world units, ending at the far plane
   ``t_far = (far - near) / dot(direction, forward)`` (as vgraph.numerics.reference_raycast).
2. Segments: each tetrahedron is the intersection of the four half-spaces of its faces; a ray's
   segment in it is ``[max(0, entry faces), min(t_far, exit faces)]``, kept where it has positive
   length. Flat tetrahedra (|6 V| <= 1e-12 * longest edge^3) are skipped. The scalar is LINEAR in
   each tetrahedron (barycentric interpolation of the point scalars, as normalised intensities
   ``mesh.normalized``; NaN and -inf count as the value range's low end, +inf as its high end), so
   along a segment it is linear in t between its values at entry and exit. A mesh of cell
   scalars (``mesh.per_cell``) is CONSTANT in each tetrahedron: the segment's two values are the
   cell's, and rule 4 gives its integral in closed form (constant colour and opacity). Segments are
   composited in order of their entry distance. Shared faces are watertight: both tetrahedra use
   the same plane (computed from the face's sorted vertex indices), so one's exit is the other's
   entry, and a ray lying exactly in a face plane (an axis-aligned view of a tetrahedralised grid)
   belongs to one side only, as if moved by an infinitesimal step along the fixed TIE_BREAK.
3. Classification: the normalised TF (``tf.for_volume(mesh)``) itself, piecewise linear between
   its points (not the 4096-entry LUT); below the first point and above the last the end values
   hold, and two points at one position are a step. Point opacities are clamped to 1 - 1e-7 so the
   extinction below stays finite.
4. Emission-absorption, integrated exactly: extinction ``tau(s) = -ln(1 - a(s)) / L`` with
   ``L = mesh.opacity_length``, emission ``c(s) tau(s)`` (premultiplied). This is the continuous
   limit of the RayCaster's compositing ``C += (1 - A) c a'``, ``a' = 1 - (1 - a)^(step / L)``.
   Along a segment of length l: ``alpha = 1 - exp(-int tau)`` and
   ``rgb = int c(u) tau(u) exp(-int_0^u tau) du``. For a constant TF over the segment this is
   ``alpha = 1 - (1 - a)^(l / L)`` and ``rgb = c alpha`` exactly. In general the segment is split
   where its scalar crosses TF points; on each piece a(u) and c(u) are linear in u, the optical
   depth has the closed form ``Tau(u) = -(u / L) mean(ln b)`` (b = 1 - a, the mean over [b(0),
   b(u)] in closed form), and integration by parts leaves ``rgb = c(h) alpha(h) - (c(h) - c(0))
   mean(alpha)`` with one smooth integral, ``mean(alpha)`` over the piece, done with 16-point
   Gauss-Legendre on sub-intervals with an optical depth of at most 4 each and, where b varies by
   more than a factor 8, geometric in b (the log singularity of tau at a -> 1). Past the point
   where the piece's optical depth reaches 40 the integrand is 1 to within exp(-40) = 4e-18 and is
   taken as 1, so the quadrature's cost is bounded at any optical depth. Accurate to ~1e-12 for
   optical depths from 0 to 1e8 and more (tests/test_reference_extremes.py). Small opacities are
   kept as given (1e-9 in the tests: log1p, expm1); large ones are clamped to MAX_OPACITY (rule
   3: about float32's last step below 1, so 1 - 1e-9, which a GL texture holds as 1, counts as
   1 - 1e-7).
5. Compositing front to back in log space (the transparency in front of a segment is exp(-the
   optical depth in front of it), its coverage -expm1(-total optical depth)), then over the background:
   ``rgb = C + (1 - A) * bg.rgb``, ``alpha = A + (1 - A) * bg.a``; a ray meeting no tetrahedron is
   the background exactly.
6. Depth (``return_depth=True``), as the ray casters' depth output: r window-space depth of the
   first point with opacity > 0 (1 where none), g its distance from the ray's start, b the number
   of segments (tetrahedra) the ray crossed, a 1 where there is such a point.
7. Memory: the image is rendered in bands of rows whose rays meet about ``band_pairs`` pixel
   boxes of tetrahedra (BAND_PAIRS) together, ray-tetrahedron pairs are tested ``chunk_pairs`` at
   a time, segments integrated SEGMENT_PIECES segment-pieces at a time and the quadrature runs
   QUADRATURE_NODES nodes at a time, so the working memory is bounded whatever the image size,
   the optical depth or the transfer function (post.vtk at 256 x 256 with opacity_length 1e-4:
   141 MiB traced; it was 5.7 GiB and a MemoryError; bench/reference_memory.py).

Images are float32 (H, W, 4), row 0 at the top; arithmetic is float64.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vgraph.camera import Camera
from vgraph.errors import VGraphError, positive_pair
from vgraph.mesh import TetMesh
from vgraph.numerics.segment_integral import MAX_OPACITY, Pieces, expand, integrate, segment_integral
from vgraph.transfer_function import TransferFunction

# segment_integral and MAX_OPACITY (rules 3 and 4) are part of this module's API; they live in
# vgraph.numerics.segment_integral
__all__ = ["MAX_OPACITY", "MODES", "Segments", "pixel_boxes", "ray_segments", "render", "segment_integral"]

MODES = ("exact",)
FLAT_TET = 1e-12  # |6 V| / longest edge^3 below this: the tetrahedron is skipped
BAND_PAIRS = 1 << 20  # pixel boxes of tetrahedra met by one band of rows, about (bounded memory)
TIE_BREAK = np.array([1.0, 0.7390851332151607, 0.5772156649015329])  # generic direction (rule 2)


# --- rays and tetrahedra ------------------------------------------------------------------------
@dataclass(frozen=True)
class Segments:
    """Where rays cross tetrahedra, sorted by ray, then entry distance: the ray (row * W + col),
    the tetrahedron, entry and exit distances from the ray's start (world units) and the
    normalised intensity there."""

    ray: np.ndarray
    tet: np.ndarray
    t_in: np.ndarray
    t_out: np.ndarray
    s_in: np.ndarray
    s_out: np.ndarray

    @property
    def length(self) -> np.ndarray:
        return self.t_out - self.t_in

    def thickness(self, size) -> np.ndarray:
        """(H, W) total length of the rays inside the mesh."""
        width, height = size
        return np.bincount(self.ray, weights=self.length, minlength=width * height).reshape(height, width)


class _Geometry:
    """Face planes and linear scalar fields of the tetrahedra. A face's plane is computed once
    from its sorted vertex indices (``normal``, ``offset``) and each tetrahedron has it with the
    sign ``side`` that makes it point outwards, so two tetrahedra sharing a face see exactly
    opposite planes: a ray crosses from one into the other at the same t, and a ray lying in the
    face belongs to one of them only (rule 2)."""

    def __init__(self, mesh: TetMesh):
        points = mesh.points.astype(np.float64)
        corners = points[mesh.tets]  # (M, 4, 3)
        edges = corners[:, 1:] - corners[:, :1]
        six_volume = np.einsum("ij,ij->i", np.cross(edges[:, 0], edges[:, 1]), edges[:, 2])
        longest = np.max([np.linalg.norm(corners[:, i] - corners[:, j], axis=1)
                          for i in range(4) for j in range(i + 1, 4)], axis=0)
        keep = np.abs(six_volume) > FLAT_TET * longest ** 3
        self.index = np.flatnonzero(keep)
        tets, corners, edges = mesh.tets[keep], corners[keep], edges[keep]
        self.corners = corners
        normals, offsets = np.empty((len(tets), 4, 3)), np.empty((len(tets), 4))
        side = np.empty((len(tets), 4))
        for face in range(4):
            vertices = np.sort(tets[:, [v for v in range(4) if v != face]], axis=1)
            a, b, c = (points[vertices[:, v]] for v in range(3))
            n = np.cross(b - a, c - a)
            normals[:, face], offsets[:, face] = n, _dot(n, a)
            side[:, face] = np.where(_dot(n, corners[:, face] - a) > 0.0, -1.0, 1.0)  # outwards
        self.normals, self.offsets, self.side = normals, offsets, side
        # A ray exactly in a face plane counts as moved by an infinitesimal TIE_BREAK: it is in
        # the tetrahedron on that side, the one whose outward normal points away from TIE_BREAK.
        self.tie_inside = side * np.einsum("mfk,k->mf", normals, TIE_BREAK) < 0.0
        self.p0 = corners[:, 0]
        if mesh.per_cell:  # one value per tetrahedron, constant inside it
            self.s0 = _intensities(mesh)[keep]
            self.gradient = np.zeros((len(tets), 3))
            return
        values = _intensities(mesh)[tets]
        self.s0 = values[:, 0]
        self.gradient = np.linalg.solve(edges, (values[:, 1:] - values[:, :1])[..., None])[..., 0]


def _dot(u, v):
    """Row-wise dot products summed in a fixed order (the same rounding for equal rows)."""
    return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1] + u[..., 2] * v[..., 2]


def _intensities(mesh: TetMesh) -> np.ndarray:
    scalars = mesh.scalars.astype(np.float64)
    if not np.all(np.isfinite(scalars)):
        lo, hi = mesh.value_range
        scalars = np.nan_to_num(scalars, nan=lo, posinf=hi, neginf=lo)
    return mesh.normalized(scalars)


def ray_segments(mesh: TetMesh, camera: Camera, size, *, chunk_pairs: int = 1 << 18) -> Segments:
    """Every ray's segments in the tetrahedra (rule 2) for the camera resolved against the mesh."""
    width, height = _check_size(size)
    camera = camera.resolved(*mesh.bounds, width / height)
    origins, directions = (a.reshape(-1, 3) for a in camera.rays(width, height))
    t_far = camera.far_distance(directions)
    geometry = _Geometry(mesh)
    boxes = pixel_boxes(geometry.corners, camera, width, height)
    return _segments(geometry, boxes, width, (0, height), origins, directions, t_far, chunk_pairs)


def _segments(geometry, boxes, width, band, origins, directions, t_far, chunk_pairs):
    """The segments of the rays in the image rows band = (first, stop), pairs of ray and
    tetrahedron tested chunk_pairs at a time."""
    c0, c1, r0, r1 = boxes
    r0, r1 = np.maximum(r0, band[0]), np.minimum(r1, band[1] - 1)
    counts = np.maximum(c1 - c0 + 1, 0) * np.maximum(r1 - r0 + 1, 0)
    parts = []
    candidates = np.flatnonzero(counts)
    bounds = np.cumsum(counts[candidates])
    start = 0
    while start < len(candidates):
        base = bounds[start - 1] if start else 0
        stop = max(int(np.searchsorted(bounds, base + chunk_pairs, side="right")), start + 1)
        tets = candidates[start:stop]
        start = stop
        tet, k, _ = expand(counts[tets])
        tet = tets[tet]
        columns = c1[tet] - c0[tet] + 1
        ray = (r0[tet] + k // columns) * width + c0[tet] + k % columns
        parts.append(_intersect(geometry, tet, ray, origins, directions, t_far))
    if not parts:
        empty = np.zeros(0)
        return Segments(np.zeros(0, np.int64), np.zeros(0, np.int64), empty, empty, empty, empty)
    ray, tet, t_in, t_out, s_in, s_out = (np.concatenate(v) for v in zip(*parts))
    order = np.lexsort((t_in, ray))
    return Segments(ray[order], geometry.index[tet[order]], t_in[order], t_out[order],
                    s_in[order], s_out[order])


def _row_bands(boxes, height, pairs):
    """Consecutive image rows (first, stop) whose rays meet at most about ``pairs`` pixel boxes of
    tetrahedra together (one row at least): the image is rendered band by band, so the memory it
    takes is bounded by ``pairs``, not by the image size."""
    c0, c1, r0, r1 = boxes
    columns = np.maximum(c1 - c0 + 1, 0)
    seen = (columns > 0) & (r1 >= r0)
    change = np.zeros(height + 1)
    np.add.at(change, r0[seen], columns[seen])
    np.add.at(change, r1[seen] + 1, -columns[seen])
    per_row = np.cumsum(change[:height])
    bands, first, total = [], 0, 0.0
    for row, count in enumerate(per_row):
        if row > first and total + count > pairs:
            bands.append((first, row))
            first, total = row, 0.0
        total += count
    bands.append((first, height))
    return bands


def pixel_boxes(corners, camera, width, height):
    """Inclusive pixel ranges (c0, c1, r0, r1) that may see each tetrahedron (or face: ``corners``
    [m, k, 3]; a one-pixel margin); the whole image for one reaching behind the eye, none (c1 = -1)
    for one wholly behind it."""
    matrix = camera.view_projection(width / height)
    clip = np.einsum("ij,mkj->mki", matrix[:, :3], corners) + matrix[:, 3]
    w = clip[..., 3]
    ahead = w > 1e-12 * np.abs(clip[..., :3]).max(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ndc = clip[..., :2] / w[..., None]
    cols = (ndc[..., 0] + 1.0) / 2.0 * width - 0.5
    rows = (1.0 - ndc[..., 1]) / 2.0 * height - 0.5
    whole = ~ahead.all(axis=1)
    cols[whole], rows[whole] = 0.0, 0.0
    c0 = np.floor(cols.min(axis=1)) - 1
    c1 = np.ceil(cols.max(axis=1)) + 1
    r0 = np.floor(rows.min(axis=1)) - 1
    r1 = np.ceil(rows.max(axis=1)) + 1
    c0[whole], c1[whole], r0[whole], r1[whole] = 0, width - 1, 0, height - 1
    behind = ~ahead.any(axis=1)
    c0, c1 = np.clip(c0, 0, width), np.clip(c1, -1, width - 1)
    r0, r1 = np.clip(r0, 0, height), np.clip(r1, -1, height - 1)
    c1[behind] = -1
    return c0.astype(np.int64), c1.astype(np.int64), r0.astype(np.int64), r1.astype(np.int64)


def _intersect(geometry, tet, ray, origins, directions, t_far):
    """Segments of rays in tetrahedra (pairs), clipped to [0, t_far]; only positive lengths."""
    o, d = origins[ray], directions[ray]
    normals, side = geometry.normals[tet], geometry.side[tet]
    denom = side * _dot(normals, d[:, None, :])
    num = side * (geometry.offsets[tet] - _dot(normals, o[:, None, :]))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = num / denom
    t_in = np.maximum(np.where(denom < 0.0, t, -np.inf).max(axis=1), 0.0)
    t_out = np.minimum(np.where(denom > 0.0, t, np.inf).min(axis=1), t_far[ray])
    outside = (denom == 0.0) & ((num < 0.0) | ((num == 0.0) & ~geometry.tie_inside[tet]))
    hit = (t_out > t_in) & ~np.any(outside, axis=1)
    tet, ray, o, d, t_in, t_out = tet[hit], ray[hit], o[hit], d[hit], t_in[hit], t_out[hit]
    g = geometry.gradient[tet]
    start = geometry.s0[tet] + np.einsum("pk,pk->p", g, o - geometry.p0[tet])
    slope = np.einsum("pk,pk->p", g, d)
    return ray, tet, t_in, t_out, start + t_in * slope, start + t_out * slope


# --- the image ----------------------------------------------------------------------------------
def render(mesh: TetMesh, camera: Camera, transfer_function: TransferFunction, size, *,
           background=(0.0, 0.0, 0.0, 1.0), mode: str = "exact", return_depth: bool = False,
           chunk_pairs: int = 1 << 18, band_pairs: int = BAND_PAIRS):
    """Render ``mesh`` with the exact emission-absorption integral (module docstring).

    ``size`` is (width, height). Returns the float32 (H, W, 4) image, row 0 at the top, and with
    ``return_depth=True`` also the float32 (H, W, 4) depth image (rule 6). The rays are rendered
    in bands of rows meeting about ``band_pairs`` pixel boxes of tetrahedra each (rule 7)."""
    width, height = _check_size(size)
    if mode not in MODES:
        raise VGraphError(f"tetrahedra reference: mode must be one of {MODES}, got {mode!r}")
    bg = np.asarray(background, dtype=np.float64)
    if bg.shape != (4,) or not np.all(np.isfinite(bg)):
        raise VGraphError("tetrahedra reference: background must be 4 finite numbers (r, g, b, a), "
                          f"got {background!r}")
    camera = camera.resolved(*mesh.bounds, width / height)
    origins, directions = (a.reshape(-1, 3) for a in camera.rays(width, height))
    t_far = camera.far_distance(directions)
    geometry = _Geometry(mesh)
    pieces = Pieces.of(transfer_function.for_volume(mesh))
    boxes = pixel_boxes(geometry.corners, camera, width, height)
    image = np.empty((width * height, 4), dtype=np.float32)
    depth_image = np.empty((width * height, 4), dtype=np.float32) if return_depth else None
    for band in _row_bands(boxes, height, band_pairs):
        segments = _segments(geometry, boxes, width, band, origins, directions, t_far, chunk_pairs)
        rays = slice(band[0] * width, band[1] * width)
        local = segments.ray - rays.start
        colour, depth, first = integrate(segments.s_in, segments.s_out, segments.length, pieces,
                                          mesh.opacity_length)
        image[rays] = _composited(local, colour, depth, rays.stop - rays.start, bg)
        if return_depth:
            depth_image[rays] = _depth_values(camera, width, height, origins[rays], directions[rays],
                                              local, segments, first)
    image = image.reshape(height, width, 4)
    if not return_depth:
        return image
    return image, depth_image.reshape(height, width, 4)


def _composited(ray, colour, depth, rays, bg):
    """Front-to-back compositing of the segments of ``rays`` rays (ray: each segment's, sorted by
    ray and entry) in log space: the transparency in front of a segment is exp(-optical depth in
    front of it), then over the background (rule 5)."""
    weight = np.exp(-_exclusive_sums(depth, ray))
    rgb = np.stack([np.bincount(ray, weights=weight * colour[:, c], minlength=rays)
                    for c in range(3)], axis=1)
    coverage = -np.expm1(-np.bincount(ray, weights=depth, minlength=rays))[:, None]
    return np.concatenate([rgb + (1.0 - coverage) * bg[:3], coverage + (1.0 - coverage) * bg[3]],
                          axis=1)


def _exclusive_sums(values, group):
    """Sum of the values before each one within its group (groups contiguous)."""
    total = np.cumsum(values) - values
    if len(values) == 0:
        return total
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    first_of = np.repeat(starts, np.diff(np.r_[starts, len(values)]))
    return np.maximum(total - total[first_of], 0.0)


def _depth_values(camera, width, height, origins, directions, ray, segments, first):
    """Rule 6 for the rays with these origins and directions (ray: each segment's, 0-based)."""
    rays = len(origins)
    t = np.full(rays, np.inf)
    np.minimum.at(t, ray, segments.t_in + first * segments.length)
    found = np.isfinite(t)
    depth = np.zeros((rays, 4))
    depth[:, 0] = 1.0
    points = origins[found] + t[found, None] * directions[found]
    matrix = camera.view_projection(width / height)
    clip = points @ matrix[:, :3].T + matrix[:, 3]
    depth[found, 0] = np.clip(0.5 + 0.5 * clip[:, 2] / clip[:, 3], 0.0, 1.0)
    depth[found, 1] = t[found]
    depth[:, 2] = np.bincount(ray, minlength=rays)
    depth[found, 3] = 1.0
    return depth


def _check_size(size) -> tuple[int, int]:
    return positive_pair(size, "tetrahedra reference: size", "(width, height)")
