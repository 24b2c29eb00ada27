"""RayRequests: the single-pass bricked ray caster's ray-guided requests (issue #33, item 2;
docs/explanations/bricked-ray-casting.md, "Ray-guided requests"): the shader counts the cells of
the frame's plan that the atlas does not hold and that its rays reached, the CPU reads the counts
back after the frame and loads those bricks by priority, and the next frame refines. The contract
of components: vgraph.gl.raycasting.raycaster_base.

Conventions:
- Only a frame whose plan misses cells in the atlas asks (define PAGED_REQUESTS; a complete frame
  pays nothing). Its ``wanted`` table (vgraph.bricks.leaf_pages, laid out as the leaf table)
  holds, per leaf texel, 1 + the index of the planned cell there that the atlas misses (0: none);
  the shader (bricks/ray_requests.glsl) adds one per ray to that cell's counter in an R32UI image
  of one texel per missing cell (REQUEST_ROW a row), so its size follows the frame's plan, not
  the volume, with image atomics (GL_ARB_shader_image_load_store, in Mesa's llvmpipe; the
  extension line is this part's GLSL, included ahead of every other part).
- A ray asks where it evaluates a sample or starts a jump over a cell not drawn, so a cell no ray
  reaches (hidden behind opaque bricks once rays stop early, outside every ray, behind mip's
  maximum of 1) is never asked for, and never read. What a ray reads only through the shading's
  differences across a cell face is not asked for (a limit: such a pixel refines once a ray enters
  the cell).
- ``by_priority``: the most pixels first (screen coverage), then the coarser level, then the key.
- ``drawn_from`` (``drawn_bricks``: for each of a list of keys): what a planned brick is drawn
  from, itself or its finest resident ancestor (the page table's walk), for the frame's report,
  its error bound, its strides and its walk grids.
"""

from __future__ import annotations

import weakref

import numpy as np

from vgraph.bricks.brick_geometry import BrickGeometry
from vgraph.bricks.leaf_pages import LeafPages
from vgraph.gl.raycasting.raycaster_base import Binding, Component
from vgraph.gl_context import release_quietly

IMAGE_UNIT = 0  # the image unit of the requests (image units are apart from texture units)
REQUEST_ROW = 1024  # missing cells' counters per row of the request image


def by_priority(requests: list) -> list:
    """``requests`` ((key, pixels)) in the order to load them: most pixels, then coarser, first."""
    return sorted(requests, key=lambda request: (-request[1], -request[0][0], request[0]))


def parent_of(geometry: BrickGeometry, key) -> tuple | None:
    """The cell of the next coarser level holding ``key``; None at the top."""
    level = key[0]
    if level + 1 >= len(geometry.grids):
        return None
    ratio = geometry.ratios[level + 1][::-1]  # children per axis, [z, y, x]
    return (level + 1,) + tuple(int(i) // int(r) for i, r in zip(key[1:], ratio))


def drawn_from(geometry: BrickGeometry, key, resident) -> tuple | None:
    """The brick a planned cell is drawn from: itself if ``resident``, else its finest resident
    ancestor; None when there is none (nothing is drawn there)."""
    while key is not None and key not in resident:
        key = parent_of(geometry, key)
    return key


def drawn_bricks(geometry: BrickGeometry, keys, resident) -> list:
    """drawn_from of each of ``keys`` (a frame's planned cells), in their order."""
    return [drawn_from(geometry, key, resident) for key in keys]


class RayRequests(Component):
    """The request image and the wanted table of one ray caster (module docstring)."""

    glsl = ("bricks/ray_requests_extension.glsl",)

    def start(self) -> None:
        self.gl: dict = {}  # "requests" (R32UI, a counter per missing cell), "wanted" (R32F, the leaf table's layout)
        weakref.finalize(self.processor, release_quietly, self.gl)
        self.frame_binding = Binding()
        self.asked = False  # whether the frame being drawn asks

    def bind(self, frame) -> Binding:
        return self.frame_binding  # made by prepare, before the pass

    def prepare(self, ctx, leaf: LeafPages) -> Binding:
        """The pass's binding for a frame whose plan the atlas misses ``leaf.missing`` of: the zeroed
        request image bound to its image unit and the wanted table; nothing when none is missing."""
        count = len(leaf.missing)
        self.asked = bool(count)
        if not self.asked:
            self.frame_binding = Binding()
            return self.frame_binding
        size = (min(count, REQUEST_ROW), -(-count // REQUEST_ROW), 1)
        requests = self._texture(ctx, "requests", size, "u4")
        requests.write(np.zeros(size[0] * size[1], dtype=np.uint32).tobytes())
        requests.bind_to_image(IMAGE_UNIT, read=True, write=True)
        table = self._texture(ctx, "wanted", leaf.wanted.shape[::-1], "f4")
        table.write(np.ascontiguousarray(leaf.wanted).tobytes())
        self.frame_binding = Binding({"PAGED_REQUESTS": True}, textures={"wanted_table": table},
                                     uniforms={"requests": IMAGE_UNIT, "request_row": size[0]})
        return self.frame_binding

    def read(self, ctx, missing) -> list:
        """(key, pixels) of the cells of ``missing`` (the frame's keys [n, 4], in its order) the last
        frame's rays reached; [] when it did not ask."""
        if not self.asked:
            return []
        ctx.memory_barrier()  # the shader's image stores, before reading the texture
        counts = np.frombuffer(self.gl["requests"].read(), dtype=np.uint32)[:len(missing)]
        return [(tuple(int(i) for i in missing[index]), int(counts[index])) for index in np.flatnonzero(counts)]

    def _texture(self, ctx, name: str, size, dtype: str):
        texture = self.gl.get(name)
        if texture is None or texture.ctx is not ctx or texture.size != tuple(size):
            release_quietly({name: texture} if texture is not None else {})
            texture = self.gl[name] = ctx.texture3d(tuple(int(n) for n in size), 1, dtype=dtype)
            texture.filter = (0x2600, 0x2600)  # GL_NEAREST: read by texelFetch
        return texture
