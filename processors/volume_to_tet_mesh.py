"""VolumeToTetMesh: a regular volume as tetrahedra, five per cell (Monsalve 2016 ch. 3), with the
cells that cannot be seen culled (Retondaro 2008's threshold classification). The cutting, its
memory cost and the culling rules: vgraph.tetrahedralize and docs/explanations/tetrahedra.md, "VolumeToTetMesh".

After process() the processor's ``kept_cells`` and ``total_cells`` say how many of the volume's
cells became tetrahedra (5 each).

The points are the voxel centres through the volume's affine (its direction too: an LPS or tilted
grid keeps its place in the world). The mesh remembers its regular grid (``TetMesh.grid``, which
lets the ProjectedTetrahedra draw it cell by cell in the grid's sweep order) only for an
axis-aligned volume: the grid holds no direction, so an oriented volume's mesh is drawn as any
tetrahedral mesh (sorted).
"""

import numpy as np

from vgraph import (Inport, OptionProperty, Outport, Processor, PropertyError, TransferFunctionProperty,
                    VectorProperty, VGraphError)
from vgraph.gl.raycasting.components import TransferFunctionLut
from vgraph.memory import available_memory
from vgraph.mesh import RegularGrid, TetMesh
from vgraph.tetrahedralize import cell_ranges, visible_cells, volume_tetrahedra
from vgraph.volume import Volume


class VolumeToTetMesh(Processor):
    """A volume as tetrahedra (5 per cell), without the cells a TF or threshold hides."""

    category = "Mesh"
    inports = [Inport("volume", Volume)]
    outports = [Outport("mesh", TetMesh)]
    culling = OptionProperty("none", choices=["none", "transfer_function", "threshold"],
                             doc="which cells are left out: none; transfer_function = cells whose "
                                 "values all have zero opacity; threshold = cells whose values all "
                                 "lie on one side of the threshold interval")
    transfer_function = TransferFunctionProperty(
        TransferFunctionLut.DEFAULT, doc="for culling = transfer_function: link it to the renderer's")
    threshold = VectorProperty(None, size=2, optional=True,
                               doc="for culling = threshold: [low, high] in data units; cells whose "
                                   "range misses it are left out; empty: the value range")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self.kept_cells: int | None = None
        self.total_cells: int | None = None

    def check(self) -> None:
        if self.threshold is not None and not self.threshold[0] <= self.threshold[1]:
            raise PropertyError(f"{self.id}.threshold", f"low must not be above high, got "
                                f"({self.threshold[0]:g}, {self.threshold[1]:g})")

    def process(self, volume: Volume) -> TetMesh:
        self.check()
        volume.require_samples(f"{self.id} ({self.type_name})")
        if min(volume.dims) < 2:
            raise VGraphError(f"{self.id}: {volume.source or 'the volume'} has no cells: it needs at "
                              f"least 2 voxels along every axis, got (x, y, z) = {volume.dims}")
        mask = self.cell_mask(volume)
        self.total_cells = int(np.prod([d - 1 for d in volume.dims]))
        self.kept_cells = self.total_cells if mask is None else int(np.count_nonzero(mask))
        if self.kept_cells == 0:
            raise VGraphError(f"{self.id}: culling = {self.culling} leaves none of the "
                              f"{self.total_cells} cells of {volume.source or 'the volume'}: "
                              f"{self._nothing_kept_hint()}")
        available = available_memory()
        points, tets, voxels = volume_tetrahedra(
            volume.data, volume.spacing, volume.origin, mask,
            available_bytes=None if available is None else int(available * 0.8),
            where=f"{self.id} ({volume.source or 'volume'})", direction=volume.direction)
        lo, hi = volume.value_range
        scalars = volume.data.reshape(-1)[voxels]
        if scalars.dtype.kind == "f":  # as the textures clamp them (docs/explanations/conventions.md)
            scalars = np.nan_to_num(scalars, nan=lo, posinf=hi, neginf=lo)
        cells = np.arange(self.total_cells) if mask is None else np.flatnonzero(mask.reshape(-1))
        grid = RegularGrid(tuple(volume.dims), tuple(map(float, volume.origin)),
                           tuple(map(float, volume.spacing)), cells) if volume.is_axis_aligned else None
        return TetMesh(points, tets, scalars, declared_range=volume.value_range,
                       reference_length=float(min(volume.spacing)), scalar_name="voxel value",
                       source=f"{volume.source or 'volume'} (cut by {self.id})", grid=grid)

    def cell_mask(self, volume: Volume) -> np.ndarray | None:
        """[z-1, y-1, x-1] bool: the cells to keep (None: all of them)."""
        if self.culling == "none":
            return None
        lo, hi = volume.value_range
        low, high = cell_ranges(volume.data, lo, hi)
        if self.culling == "threshold":
            if self.threshold is None:
                return None
            t_low, t_high = self.threshold
            return (high >= t_low) & (low <= t_high)
        alpha = self.transfer_function.for_volume(volume).lut()[:, 3]
        mask = np.empty(low.shape, dtype=bool)
        for k in range(low.shape[0]):  # slab by slab: normalised float64 copies stay small
            mask[k] = visible_cells(volume.normalized(low[k]), volume.normalized(high[k]), alpha)
        return mask

    def _nothing_kept_hint(self) -> str:
        if self.culling == "threshold":
            return f"no cell's values reach the threshold {tuple(self.threshold)}"
        return "the transfer function gives every value in the volume zero opacity"
