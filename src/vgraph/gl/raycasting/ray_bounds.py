"""Ray bounds from the occupied blocks (RAY_BOUNDS, docs/explanations/ray-casting.md): per pixel, the nearest and
farthest point of its ray that is inside a block that can contribute, so that a ray
samples only between them and a ray that meets no such block is not marched at all (proxy
geometry as in Voreen, tightened to the blocks of empty-space skipping, in pairs: 8^3 voxels).

How it is exact:
- The occupied blocks (those empty-space skipping keeps, radius 0), coarsened to WALK_BLOCK^3
  voxels (occupied where one of its eight is: the boxes stay a few hundred, the pass's cost), are
  merged greedily into boxes, rebuilt only when the skip blocks are (volume, TF or iso level).
  Block k covers the samples with floor(u) in [8k, 8k + 8), u = voxel coordinate; a box's extent
  in u is clamped to the box of the voxel centres [0, dims - 1], where the entry points are
  clamped to.
- Each box is grown by GROW voxels before its ray interval is computed. A sample within one voxel
  (Chebyshev, in u) of an empty block reconstructs only from voxels inside that block's range
  window (block ranges carry a one-voxel margin), so it cannot contribute: growing by less than one
  voxel only adds samples that contribute nothing, and gives rays that graze a box a margin
  against float rounding.
- The boxes are rasterised into a target of one texel per TILE x TILE pixels (back faces only: one
  fragment per box and texel, also with the camera inside a box). The texel's ray is the one
  through the tile's centre; each box is first grown by how far the tile's other rays get from it
  within the box's depth, so the centre ray's interval holds theirs, with depth from the near
  plane as the common parameter (Camera.rays: direction component 1 along the view). It is drawn
  grown by GROW voxels more, so that every texel whose ray meets the grown box gets a fragment
  despite the rasteriser's sub-pixel snapping; the fragment intersects its ray with the grown box
  exactly (slab test) and writes (enter, -leave) into an RG32F target blended with MIN. The shader
  (ray_bounds.glsl) keeps the samples within one step of [enter, leave] (samples keep their
  positions start + i * step), so the image does not change.
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from vgraph.gl.passes import set_uniforms
from vgraph.gl.raycasting.empty_space import WALK_BLOCK, pairs_reduced
from vgraph.gl.raycasting.geometry import VolumeGeometry, cube_triangles, pixel_rays, vec
from vgraph.gl.shaders import programs

SHADERS = ("raycasting/ray_bounds.vert.glsl", "raycasting/ray_bounds.frag.glsl")
GROW = 0.5  # voxels: see the module docstring (below one voxel, the blocks' range margin)
TILE = 4  # pixels per bounds texel and axis: 1/16 of the fragments, bounds a few voxels looser
FAR = 1e30  # the cleared value: no occupied box along the pixel's ray
# Where the pass costs more than it saves (measured at 512^2, docs/reports/performance.md): with most
# blocks occupied little is left to cut, and scattered blocks make many boxes (the pass took 2-3 ms
# for 300-600 boxes, 11 ms for 1075, 15 ms for 2034; the bounds saved 0-8 ms a frame).
MAX_OCCUPIED_FRACTION = 0.75
MAX_BOXES = 1024


def occupied_boxes(occupied: np.ndarray) -> np.ndarray:
    """Disjoint boxes covering exactly the True blocks of ``occupied`` [bz, by, bx]: int array (n, 6)
    of (x0, y0, z0, x1, y1, z1), block indices, end exclusive. Runs along x, merged along y where
    the same run continues in the next row, then along z where the same rectangle continues in
    the next slab (whole-array numpy: a TF edit rebuilds them in milliseconds). A few hundred
    boxes for the 32^3 blocks of a 256^3 volume, where the blocks themselves are thousands."""
    edges = np.diff(np.pad(occupied.astype(np.int8), [(0, 0), (0, 0), (1, 1)]), axis=2)
    z, y, x0 = np.nonzero(edges == 1)
    x1 = np.nonzero(edges == -1)[2]  # row-major order: each run's end comes right after its start
    (z, x0, x1), y0, y1 = _join((z, x0, x1), y, y + 1)
    (y0, y1, x0, x1), z0, z1 = _join((y0, y1, x0, x1), z, z + 1)
    return np.stack([x0, y0, z0, x1, y1, z1], axis=1).astype(np.int64).reshape(-1, 6)


def _join(keys, start, end):
    """Join items with equal ``keys`` whose [start, end) follow each other along one axis."""
    if len(start) == 0:
        return keys, start, end
    order = np.lexsort((start, *keys[::-1]))
    keys, start, end = [k[order] for k in keys], start[order], end[order]
    same = np.all([k[1:] == k[:-1] for k in keys], axis=0) & (start[1:] == end[:-1])
    first = np.flatnonzero(np.concatenate([[True], ~same]))
    last = np.append(first[1:], len(start)) - 1
    return [k[first] for k in keys], start[first], end[last]


def world_boxes(boxes: np.ndarray, geometry: VolumeGeometry) -> np.ndarray:
    """float32 (n, 6): world (min, max) of each block box, clamped to the voxel-centre box and grown
    by GROW voxels (module docstring)."""
    last = geometry.dims - 1.0
    lo = np.minimum(boxes[:, :3] * float(WALK_BLOCK), last) - GROW
    hi = np.minimum(boxes[:, 3:] * float(WALK_BLOCK), last) + GROW
    to_world = lambda u: geometry.origin + u * geometry.spacing  # noqa: E731
    return np.hstack([to_world(lo), to_world(hi)]).astype(np.float32)


def worthwhile_boxes(occupied: np.ndarray) -> np.ndarray | None:
    """occupied_boxes, or None where the pass would cost more than it saves (module constants)."""
    if not occupied.any() or occupied.mean() > MAX_OCCUPIED_FRACTION:
        return None
    boxes = occupied_boxes(occupied)
    return boxes if len(boxes) <= MAX_BOXES else None


class RayBounds:
    """The proxy boxes of one ray caster (rebuilt when its skip blocks are) and the per-frame RG32F
    target of (nearest entry, -farthest exit) per tile, as depth from the near plane."""

    def __init__(self):
        self._key = None
        self._count = 0
        self._buffer = None  # per-instance world boxes
        self._cube = None
        self._arrays: dict = {}
        self._texture = None
        self._framebuffer = None
        self._frame = None  # the frame the target holds (ray casters with two passes draw it once)

    def texture(self, frame, key, occupied: np.ndarray | None):
        """The bounds texture of this frame, or None when the bounds do not pay.
        ``occupied``: the skip blocks' (BLOCK^3 voxels); ``key``: what they depend on."""
        if occupied is None:
            return None
        ctx = frame.ctx
        if self._key is None or not all(a is b or a == b for a, b in zip(key, self._key)):
            self._key, self._frame = key, None
            boxes = worthwhile_boxes(pairs_reduced(occupied, np.logical_or))
            self._upload(ctx, None if boxes is None else world_boxes(boxes, frame.geometry))
        if self._count == 0:
            return None
        if self._frame is not frame:
            self._draw(frame)
            self._frame = frame
        return self._texture

    def _upload(self, ctx: moderngl.Context, boxes: np.ndarray | None) -> None:
        self._count = 0 if boxes is None else len(boxes)
        if self._buffer is not None and self._buffer.ctx is ctx:
            for array in self._arrays.values():
                array.release()
            self._buffer.release()
        self._buffer, self._arrays = None, {}
        if self._count:
            self._buffer = ctx.buffer(boxes.tobytes())

    def _target(self, ctx: moderngl.Context, size) -> None:
        coarse = tuple(-(-n // TILE) for n in size)
        if self._texture is None or self._texture.ctx is not ctx or self._texture.size != coarse:
            if self._texture is not None and self._texture.ctx is ctx:
                self._framebuffer.release()
                self._texture.release()
            self._texture = ctx.texture(coarse, 2, dtype="f4")
            self._framebuffer = ctx.framebuffer(color_attachments=[self._texture])

    def _vertex_array(self, ctx, program):
        if self._cube is None or self._cube[0] is not ctx:
            self._cube = (ctx, ctx.buffer(cube_triangles().tobytes()))
            self._arrays = {}
        if program not in self._arrays:
            self._arrays[program] = ctx.vertex_array(
                program, [(self._cube[1], "3f", "corner"), (self._buffer, "3f 3f/i", "box_min", "box_max")])
        return self._arrays[program]

    def _draw(self, frame) -> None:
        ctx, size, camera = frame.ctx, tuple(frame.size), frame.camera
        self._target(ctx, size)
        program = programs.program(ctx, *SHADERS)
        geometry = frame.geometry
        rays = pixel_rays(camera, size)  # a tile of a picture: the whole picture's rays
        coarse = self._texture.size
        # The farthest a tile's pixel centre is from the tile's centre, in NDC per axis.
        half_x, half_y = (TILE / v for v in rays["viewport_size"])
        length = lambda name: math.hypot(*rays[name])  # noqa: E731
        uniforms = {"view_projection": camera.view_projection(size[0] / size[1]),
                    "coarse_scale": (size[0] / (TILE * coarse[0]), size[1] / (TILE * coarse[1])),
                    "coverage_margin": vec(GROW * geometry.spacing), "view_forward": vec(camera.basis()[2]),
                    "tile_near": half_x * length("near_right") + half_y * length("near_up"),
                    "tile_spread": half_x * length("direction_right") + half_y * length("direction_up"),
                    "ray_bounds_tile": TILE,
                    "near_to_far": float(camera.far - camera.near), **rays}
        set_uniforms(program, uniforms)
        self._framebuffer.use()
        self._framebuffer.clear(FAR, FAR, 0.0, 0.0)
        ctx.viewport = (0, 0, *coarse)
        # Back faces only: every pixel whose ray meets a box gets exactly one fragment of it.
        ctx.front_face, ctx.cull_face = "ccw", "front"
        ctx.enable(moderngl.CULL_FACE | moderngl.BLEND)
        ctx.blend_equation = moderngl.MIN
        try:
            self._vertex_array(ctx, program).render(moderngl.TRIANGLES, instances=self._count)
        finally:
            ctx.blend_equation = moderngl.FUNC_ADD
            ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
            ctx.cull_face = "back"
