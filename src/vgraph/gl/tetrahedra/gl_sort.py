"""The centroid sort on the GL side: keys, a bitonic sorting network and the gather of the sorted
tetrahedra, all in compute shaders (GL 4.3), so the index buffer never goes through the CPU.

Measured against numpy's argsort in bench/bench_tetra.py --sort (docs/explanations/tetrahedra-renderer.md,
Visibility order): on llvmpipe the network's n log^2 n compare-exchanges lose to numpy's n log n
sort; on a GPU the same code runs in parallel across thousands of cores. Same order as
``order.back_to_front`` up to ties (equal keys may come out in another order).
"""

from __future__ import annotations

import numpy as np

from vgraph.camera import Camera
from vgraph.gl.raycasting.geometry import vec
from vgraph.gl.shaders import programs

GROUP = 256


def _groups(count: int) -> int:
    return max(1, -(-count // GROUP))


class GLCentroidSort:
    """Sorts the tetrahedra of ``tets`` (an int32 (M, 4) array, uploaded once) by centroid depth,
    farthest first, into ``self.sorted`` (a GL buffer usable as the index buffer)."""

    def __init__(self, ctx, points_buffer, tets: np.ndarray):
        self.ctx, self.points = ctx, points_buffer
        self.count = len(tets)
        self.padded = 1 << max(0, (self.count - 1).bit_length())
        self.tets = ctx.buffer(np.ascontiguousarray(tets, dtype=np.int32).tobytes())
        self.keys = ctx.buffer(reserve=4 * self.padded)
        self.values = ctx.buffer(reserve=4 * self.padded)
        self.sorted = ctx.buffer(reserve=16 * self.count)
        self.passes = 0

    def sort(self, camera: Camera) -> None:
        ctx = self.ctx
        perspective = camera.projection == "perspective"
        keys = programs.compute(ctx, "tetrahedra/sort_keys.comp.glsl", {"PERSPECTIVE": perspective})
        bitonic = programs.compute(ctx, "tetrahedra/bitonic.comp.glsl")
        gather = programs.compute(ctx, "tetrahedra/gather.comp.glsl")
        self.points.bind_to_storage_buffer(0)
        self.tets.bind_to_storage_buffer(1)
        self.keys.bind_to_storage_buffer(2)
        self.values.bind_to_storage_buffer(3)
        self.sorted.bind_to_storage_buffer(4)
        keys["count"].value = self.count
        keys["eye"].value = vec(camera.position)
        if not perspective:
            keys["view_forward"].value = vec(camera.basis()[2])
        keys.run(_groups(self.padded))
        self.passes = 0
        k = 2
        while k <= self.padded:
            j = k // 2
            while j >= 1:
                ctx.memory_barrier()
                bitonic["k"].value, bitonic["j"].value = k, j
                bitonic.run(_groups(self.padded))
                self.passes += 1
                j //= 2
            k *= 2
        ctx.memory_barrier()
        gather["count"].value = self.count
        gather.run(_groups(self.count))
        ctx.memory_barrier()

    def release(self) -> None:
        for buffer in (self.tets, self.keys, self.values, self.sorted):
            buffer.release()
