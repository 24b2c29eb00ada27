"""GL side of the bricked ray caster: the accumulation targets its brick passes blend into and the
per-brick uniforms that map the global sample lattice into a brick's texture."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.cache import BLOCK, HALO, brick_extent
from vgraph.gl.raycasting.geometry import vec
from vgraph.gl_context import bind_default_framebuffer, release_quietly


class Accumulation:
    """The bricks' accumulation: two RGBA32F textures (the blended sums, the first depth samples)
    and a depth texture (MIP's maximum as 1 - depth) in one framebuffer, and a scratch pair in
    another (dvr with early termination draws a brick there, reading the accumulation, and copies
    its rectangle back); kept while the size stays the same. The GL objects live in ``gl`` (a
    dict), which a finalizer of the owner can release."""

    def __init__(self):
        self.gl: dict = {}
        self.size = (0, 0)

    @property
    def framebuffer(self):
        return self.gl["framebuffer"]

    @property
    def textures(self) -> list:
        return [self.gl["sum"], self.gl["first"]]

    @property
    def scratch(self) -> SimpleNamespace:
        """The scratch pair as a pass target (framebuffer, size) and its textures."""
        return SimpleNamespace(framebuffer=self.gl["scratch"], size=self.size,
                               textures=[self.gl["scratch_sum"], self.gl["scratch_first"]])

    def ensure(self, ctx, size) -> "Accumulation":
        size = tuple(int(v) for v in size)
        current = self.gl.get("framebuffer")
        if current is None or current.ctx is not ctx or self.size != size:
            if current is not None and current.ctx is ctx:
                self.release()
            self.gl.clear()  # (objects of a replaced context went with it)
            names = ("sum", "first", "scratch_sum", "scratch_first")
            textures = {name: ctx.texture(size, 4, dtype="f4") for name in names}
            depth = ctx.depth_texture(size)
            self.gl.update(framebuffer=ctx.framebuffer(color_attachments=[textures["sum"], textures["first"]],
                                                       depth_attachment=depth),
                           scratch=ctx.framebuffer(color_attachments=[textures["scratch_sum"],
                                                                      textures["scratch_first"]]),
                           depth=depth, **textures)
            self.size = size
        return self

    def clear(self) -> None:
        self.framebuffer.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)

    def release(self) -> None:
        if self.gl:
            bind_default_framebuffer(self.framebuffer.ctx)
            release_quietly(self.gl)
        self.size = (0, 0)


KEPT_BRICKS = 1 << 16  # bricks whose uniforms a geometry keeps (then it starts again): a few MB at most


def brick_uniforms(geometry: BrickGeometry, key) -> dict:
    """Uniforms of bricks/brick_sampling.glsl and brick_span.glsl for one brick (float64 here):
    a level-0 texture coordinate t is at level voxel u = (o0 + (t n0 - 1/2) s0 - oL) / sL, and at
    coordinate (u - (start - HALO) + 1/2) / m in the brick's texture of m voxels. Worked out once
    per brick of a geometry (kept in ``geometry.per_brick``; BrickGeometry.of keeps one per
    source), not in every frame's pass per brick; a new dict each call (callers add to it)."""
    kept = geometry.per_brick.get(key)
    if kept is None:
        if len(geometry.per_brick) >= KEPT_BRICKS:
            geometry.per_brick.clear()
        kept = geometry.per_brick[key] = _brick_uniforms(geometry, key)
    return dict(kept)


def _brick_uniforms(geometry: BrickGeometry, key) -> dict:
    source = geometry.source
    level = source.levels[key[0]]
    start, stop = brick_extent(source, key)
    start, m = start[::-1].astype(np.float64), (stop - start + 2 * HALO)[::-1].astype(np.float64)
    s_level, o_level = np.asarray(level.spacing), np.asarray(level.origin)
    scale = geometry.dims0 * geometry.spacing0 / (s_level * m)
    offset = ((geometry.origin0 - 0.5 * geometry.spacing0 - o_level) / s_level - start + HALO + 0.5) / m
    lo, hi = geometry.owner_bounds(key)
    core = m - 2 * HALO  # (x, y, z)
    return {"brick_scale": vec(scale), "brick_offset": vec(offset), "owner_lo": vec(lo), "owner_hi": vec(hi),
            "brick_texels": vec(m), "block_count": tuple(int(-(-int(n) // BLOCK)) for n in core),
            "level_stride": geometry.strides[key[0]]}


def level_voxel(geometry: BrickGeometry, level: int) -> np.ndarray:
    """One voxel of ``level`` in level-0 texture space (x, y, z), and its spacing."""
    spacing = np.asarray(geometry.source.levels[level].spacing)
    return spacing / (geometry.spacing0 * geometry.dims0), spacing
