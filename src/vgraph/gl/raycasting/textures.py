"""Samplers and look-up tables: the volume's trilinear sampler, transfer-function and colour-map
LUT textures.

Sampling: ray casters sample through a sampler object with linear filtering and clamp-to-edge (the
volume's own texture keeps its state). uint8 volumes are sampled from an R16 copy holding value *
257, which is the same normalised value: llvmpipe filters 8-bit textures with 8-bit weights (errors
up to 0.007 of the range) but 16-bit and float textures with float weights (~1e-7), and R16 is also
the fastest format there.
"""

from __future__ import annotations

from typing import Callable

import moderngl
import numpy as np

from vgraph import derived
from vgraph.transfer_function import LUT_SIZE, TransferFunction
from vgraph.volume import Volume


def linear_sampler(ctx: moderngl.Context):
    """A sampler object with linear filtering and clamp-to-edge (one per context: derived data of
    the context, vgraph.derived)."""
    return derived.value(ctx, "linear sampler", lambda: ctx.sampler(
        repeat_x=False, repeat_y=False, repeat_z=False, filter=(moderngl.LINEAR, moderngl.LINEAR)), ctx=ctx)


class LookupTexture:
    """A table of RGBA rows as a ``size`` x 1 RGBA32F texture with linear filtering and
    clamp-to-edge, rewritten only when its key changes. Row i sits at texture coordinate
    (i + 0.5) / size, so a value v in [0, 1] is looked up at v * (size - 1) / size + 0.5 / size."""

    def __init__(self, size: int):
        self.size = size
        self.texture = None
        self.key = None

    def update(self, ctx: moderngl.Context, key, table: Callable[[], np.ndarray]):
        """The texture holding ``table()`` (called only when ``key`` differs from the last one)."""
        if self.texture is None or self.texture.ctx is not ctx:
            self.texture = ctx.texture((self.size, 1), 4, dtype="f4")
            self.texture.repeat_x = self.texture.repeat_y = False
            self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.key = None
        if key is not self.key and key != self.key:
            self.texture.write(np.ascontiguousarray(table(), dtype=np.float32).tobytes())
            self.key = key
        return self.texture


class TransferFunctionTexture(LookupTexture):
    """The TF's 4096-entry LUT for a volume (TransferFunction.for_volume: TFs in data units or
    percentiles land on the volume's value range); ``alpha`` keeps its opacities for skipping."""

    def __init__(self):
        super().__init__(LUT_SIZE)
        self.alpha: np.ndarray | None = None

    def update(self, ctx: moderngl.Context, transfer_function: TransferFunction, volume: Volume):
        resolved = placed_for(transfer_function, volume)
        return super().update(ctx, resolved, lambda: self._table(resolved))

    def _table(self, resolved: TransferFunction) -> np.ndarray:
        lut = resolved.lut()
        self.alpha = lut[:, 3].copy()
        return lut


def placed_for(transfer_function: TransferFunction, volume: Volume) -> TransferFunction:
    """transfer_function.for_volume(volume), kept per volume while the TF (frozen) is the same
    (vgraph.derived): a frame asks for it once per texture it binds and per skipping table, and it
    depends on the TF and the volume's values alone."""
    return derived.value(volume, "transfer function placed", lambda: transfer_function.for_volume(volume),
                         params=transfer_function)


def needs_bricks(volume: Volume, ctx) -> bool:
    """Whether one 3D texture cannot hold the volume: wider than the GL's limit on an axis, or a
    BrickedVolume whose whole array exceeds its memory budget."""
    if max(volume.dims) > ctx.info["GL_MAX_3D_TEXTURE_SIZE"]:
        return True
    return volume.bricks is not None and not getattr(volume, "fits_budget", True)
