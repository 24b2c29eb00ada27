"""The brick atlas of the single-pass bricked ray caster (issue #33, item 1): one 3D texture of fixed
size holding resident bricks of any level, each in a slot (docs/explanations/bricked-ray-casting.md,
"One pass, a page table").

Conventions:
- A slot holds one brick as the brick cache keeps it (vgraph.bricks.cache.read_with_halo): its
  core voxels with an apron of HALO = 2 voxels on every side, read from the neighbours (replicated
  at the level's border). One voxel of apron makes trilinear filtering of every sample a brick owns
  exact; the second one keeps the shading's central and Sobel differences exact too, so a slot
  answers every read of a sample it owns and level 0 equals the in-core image.
- Every slot has the shape of the largest brick with its apron (``slot_shape``, x, y, z); a brick
  smaller than that (at a level's far faces) fills the slot's low corner. Slots are laid out in a
  grid (``slot_grid``) inside the texture; slot s sits at texel ``slot_origin(s)``.
- The number of slots: as many as ``budget_bytes`` holds, no more than the pyramid has bricks (a
  small volume gets a small atlas), each axis within GL_MAX_3D_TEXTURE_SIZE. A budget that would
  need a texture past that limit, or holds not one slot, is refused (ValueError; the component
  names the processor's property).
- Slots are reused least recently used first, never a pinned one (the frame's bricks): ``place``
  returns the slot of a brick, uploading it into a free or evicted slot on a miss, or None when
  every slot is pinned. ``stats`` counts uploads and evictions. With each brick go the ranges of
  its blocks (``blocks``, vgraph.bricks.atlas_blocks), for skipping inside it.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from vgraph import derived
from vgraph.bricks.atlas_blocks import AtlasBlocks
from vgraph.bricks.cache import HALO, TextureFormat
from vgraph.bricks.cells import table_of
from vgraph.gl_context import release_quietly


def slot_shape_of(source) -> tuple[int, int, int]:
    """(x, y, z) texels of the largest brick of any level with its apron (made once per table of
    cells, vgraph.derived: every frame asks, and it depends on the pyramid alone)."""
    table = table_of(source)
    return derived.value(table, "atlas slot shape", lambda: _slot_shape(table))


def _slot_shape(table) -> tuple[int, int, int]:
    spans = table.spans  # per level, per axis [z, y, x]: (starts, stops)
    largest = [max(int(np.max(stops - starts)) for level in spans for starts, stops in [level[axis]])
               for axis in range(3)]
    return tuple(n + 2 * HALO for n in largest[::-1])


def max_texture_size(ctx) -> int:
    """Texels per axis of this GL's largest 3D texture."""
    return int(ctx.info["GL_MAX_3D_TEXTURE_SIZE"])


def brick_count(source) -> int:
    """Bricks (cells) of every level of the pyramid."""
    return sum(math.prod(grid) for grid in table_of(source).grids)


def slot_grid_of(slots: int, slot_shape, max_size: int) -> tuple[int, int, int]:
    """A near-cubic (x, y, z) grid of at least ``slots`` slots whose texture fits ``max_size`` texels
    per axis; ValueError when none does."""
    per_axis = [max_size // n for n in slot_shape]
    if math.prod(per_axis) < slots:
        raise ValueError(f"{slots} slots of {'x'.join(map(str, slot_shape))} texels need a 3D texture "
                         f"larger than this GL's limit of {max_size} texels per axis (GL_MAX_3D_TEXTURE_SIZE)")
    side = max(1, math.ceil(slots ** (1.0 / 3.0)))
    x = min(per_axis[0], side)
    y = min(per_axis[1], max(1, math.ceil(math.sqrt(slots / x))))
    z = min(per_axis[2], math.ceil(slots / (x * y)))
    while x * y * z < slots:  # an axis hit the limit: grow the others
        if y < per_axis[1]:
            y += 1
        elif x < per_axis[0]:
            x += 1
        else:
            z += 1
    return x, y, z


class BrickAtlas:
    """Resident bricks in slots of one 3D texture (module docstring). One per ray caster; it is
    rebuilt (``ensure``) when the source, its texture format, the budget or the context changes."""

    def __init__(self):
        self.gl: dict = {}  # "texture": the atlas (released with the owner)
        self.key = self.source = None
        self.slots: OrderedDict = OrderedDict()  # brick key -> slot, least recently used first
        self.free: list[int] = []
        self.pinned: frozenset = frozenset()
        self.stats = {"uploads": 0, "evictions": 0}

    @property
    def texture(self):
        return self.gl["texture"]

    def ensure(self, ctx, source, fmt: TextureFormat, budget_bytes: int) -> "BrickAtlas":
        """The atlas for ``source`` under ``budget_bytes`` on ``ctx`` (module docstring)."""
        key = (fmt, int(budget_bytes))
        texture = self.gl.get("texture")
        if key == self.key and source is self.source and texture is not None and texture.ctx is ctx:
            return self
        slot_shape = slot_shape_of(source)
        slot_bytes = math.prod(slot_shape) * fmt.itemsize
        slots = min(int(budget_bytes) // slot_bytes, brick_count(source))
        if slots < 1:
            raise ValueError(f"the budget ({budget_bytes / 2**20:.3g} MB) does not hold one brick "
                             f"({'x'.join(map(str, slot_shape))} texels with its apron, "
                             f"{slot_bytes / 2**20:.3g} MB)")
        grid = slot_grid_of(slots, slot_shape, max_texture_size(ctx))
        self.release()
        size = tuple(g * n for g, n in zip(grid, slot_shape))
        texture = ctx.texture3d(size, 1, dtype=fmt.gl_dtype)
        texture.repeat_x = texture.repeat_y = texture.repeat_z = False
        self.gl["texture"] = texture
        self.key, self.source = key, source  # (the source by identity: another one's bricks are not these)
        self.slot_shape, self.slot_grid, self.capacity = slot_shape, grid, slots
        self.size = size
        self.blocks = AtlasBlocks(slot_shape, grid, fmt, self.gl)  # the slots' block ranges (skipping)
        self.slots.clear()
        self.free = list(range(slots))
        return self

    def slot_origin(self, slot: int) -> tuple[int, int, int]:
        """(x, y, z) texel of the slot's first texel."""
        gx, gy, _ = self.slot_grid
        index = (slot % gx, slot // gx % gy, slot // (gx * gy))
        return tuple(i * n for i, n in zip(index, self.slot_shape))

    def resident(self) -> tuple[np.ndarray, np.ndarray]:
        """The resident bricks' keys [n, 4] and their slots' origins [n, 3] (x, y, z)."""
        keys = np.asarray(list(self.slots), dtype=np.int64).reshape(-1, 4)
        slots = np.fromiter(self.slots.values(), dtype=np.int64, count=len(self.slots))
        gx, gy, _ = self.slot_grid
        index = np.stack([slots % gx, slots // gx % gy, slots // (gx * gy)], axis=-1)
        return keys, index * np.asarray(self.slot_shape, dtype=np.int64)

    def begin_frame(self, keys) -> None:
        """Pin the bricks of this frame: placing others never evicts them."""
        self.pinned = frozenset(keys)

    def slot_of(self, key) -> int | None:
        """The brick's slot if it is resident (no upload; counts as a use)."""
        slot = self.slots.get(key)
        if slot is not None:
            self.slots.move_to_end(key)
        return slot

    def place(self, key, data) -> int | None:
        """The brick's slot, uploading ``data()`` (its voxels with the apron, [z, y, x], in the
        texture's values) on a miss into a free slot or the least recently used unpinned one; None
        when every slot holds a pinned brick."""
        slot = self.slot_of(key)
        if slot is not None:
            return slot
        if self.free:
            slot = self.free.pop(0)
        else:
            victim = next((old for old in self.slots if old not in self.pinned), None)
            if victim is None:
                return None
            slot = self.slots.pop(victim)
            self.stats["evictions"] += 1
        block = np.ascontiguousarray(data())
        nz, ny, nx = block.shape
        x, y, z = self.slot_origin(slot)
        self.texture.write(block.tobytes(), viewport=(x, y, z, nx, ny, nz), alignment=1)
        self.blocks.record(slot, block)
        self.slots[key] = slot
        self.stats["uploads"] += 1
        return slot

    def place_all(self, keys, data) -> list:
        """``place`` for each of ``keys`` in order, ``data(key)`` its voxels on a miss: the keys that
        got a slot. One loop: a frame of thousands of resident bricks only marks them used."""
        slots, placed = self.slots, []
        for key in keys:
            if key in slots:
                slots.move_to_end(key)
                placed.append(key)
            elif self.place(key, lambda key=key: data(key)) is not None:
                placed.append(key)
        return placed

    def evict(self, key) -> None:
        """Forget a brick (its slot becomes free); nothing when it is not resident."""
        slot = self.slots.pop(key, None)
        if slot is not None:
            self.free.append(slot)
            self.stats["evictions"] += 1

    def release(self) -> None:
        release_quietly(self.gl)
        self.gl.clear()
        self.key = self.source = None
        self.slots.clear()
        self.free = []
