"""The TetMesh data type: tetrahedra with one scalar per point, in world units.

Conventions (docs/explanations/conventions.md; the same as Volume's where they overlap):
- ``points`` (N, 3) float32 world coordinates (x, y, z); ``tets`` (M, 4) int32 indices into them;
  ``scalars`` (N,) float32, the point scalar the renderer classifies, linear inside each
  tetrahedron; or, with ``per_cell``, (M,) float32, one value per tetrahedron, constant inside it
  (a file's cell array: a piecewise-constant field, whose ray integral is exact cell by cell).
- ``value_range`` maps scalars to normalised intensities in [0, 1]: the declared range if given,
  else the finite min..max (a constant mesh gets a representable range, as volumes do). Transfer
  functions in data units and percentiles resolve through it (TransferFunction.for_volume works on
  a TetMesh: it only needs ``value_range`` and ``percentiles``).
- ``reference_length`` is the length in world units over which a transfer function's opacity is
  the opacity of one sample at sampling rate 1: the smallest voxel spacing for meshes made from a
  volume (so a volume and its tetrahedra look alike), else what the source states (default: the
  mean edge length).
- GL buffers are uploaded lazily per context (``buffers(ctx)``) and released with the mesh.
- ``grid`` (a RegularGrid) says that the mesh was cut from a regular volume by VolumeToTetMesh, five
  tetrahedra per kept cell in the order of ``grid.cells``: renderers may then work cell by cell
  (ProjectedTetrahedra's sweep order and cell projection). Other meshes have none.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from vgraph import derived
from vgraph.errors import VGraphError
from vgraph.value_range import checked_range, range_of


@dataclass(frozen=True, eq=False)
class RegularGrid:
    """The regular grid behind a mesh made by VolumeToTetMesh: point (i, j, k) is the voxel centre
    ``origin + (i, j, k) * spacing``; cell (i, j, k) spans points (i..i+1, j..j+1, k..k+1) and has
    the linear index ``i + (nx - 1) * (j + (ny - 1) * k)``. ``cells`` lists the kept cells in
    ascending order; tetrahedra 5c..5c+4 of the mesh are the five of ``cells[c]`` (the templates
    of vgraph.tetrahedralize.CELL_TETS, by the parity of i + j + k)."""
    dims: tuple[int, int, int]  # points (voxels) along x, y, z
    origin: tuple[float, float, float]
    spacing: tuple[float, float, float]
    cells: np.ndarray  # (K,) int64

    @property
    def cell_dims(self) -> tuple[int, int, int]:
        return tuple(d - 1 for d in self.dims)

    @cached_property
    def positions(self) -> np.ndarray:
        """[z, y, x] int32 over all cells: each cell's position in ``cells``, -1 where culled (the
        sweep order picks the kept cells with it every time the camera moves)."""
        nx, ny, nz = self.cell_dims
        position = np.full(nx * ny * nz, -1, dtype=np.int32)
        position[self.cells] = np.arange(len(self.cells), dtype=np.int32)
        return position.reshape(nz, ny, nx)

    def cell_indices(self) -> np.ndarray:
        """(K, 3) int64 (i, j, k) of the kept cells."""
        nx, ny, _ = self.cell_dims
        return np.stack([self.cells % nx, (self.cells // nx) % ny, self.cells // (nx * ny)], axis=1)


@dataclass(eq=False)
class TetMesh:
    points: np.ndarray
    tets: np.ndarray
    scalars: np.ndarray
    declared_range: tuple[float, float] | None = None
    reference_length: float | None = None
    scalar_name: str = ""
    source: str = ""  # where it came from, for messages
    grid: RegularGrid | None = None
    per_cell: bool = False  # scalars: one per tetrahedron (constant inside it), not one per point

    def __post_init__(self):
        where = f" from {self.source}" if self.source else ""
        self.points = np.ascontiguousarray(self.points, dtype=np.float32)
        self.tets = np.ascontiguousarray(self.tets, dtype=np.int32)
        self.scalars = np.ascontiguousarray(self.scalars, dtype=np.float32).reshape(-1)
        if self.points.ndim != 2 or self.points.shape[1] != 3 or len(self.points) == 0:
            raise VGraphError(f"mesh{where}: points must be a non-empty (N, 3) array, got {self.points.shape}")
        if self.tets.ndim != 2 or self.tets.shape[1] != 4 or len(self.tets) == 0:
            raise VGraphError(f"mesh{where}: tetrahedra must be a non-empty (M, 4) array, got {self.tets.shape}")
        carriers = (len(self.tets), "tetrahedra") if self.per_cell else (len(self.points), "points")
        if len(self.scalars) != carriers[0]:
            raise VGraphError(f"mesh{where}: {len(self.scalars)} scalars for {carriers[0]} {carriers[1]}")
        if not np.all(np.isfinite(self.points)):
            raise VGraphError(f"mesh{where}: {int((~np.isfinite(self.points)).any(axis=1).sum())} points "
                              f"have non-finite coordinates")
        if self.tets.min() < 0 or self.tets.max() >= len(self.points):
            raise VGraphError(f"mesh{where}: tetrahedron indices must lie in 0 .. {len(self.points) - 1}, "
                              f"found {int(self.tets.min())} .. {int(self.tets.max())}")
        self.declared_range = checked_range(self.declared_range, f"mesh{where}")
        if self.grid is not None and self.per_cell:
            raise VGraphError(f"mesh{where}: a mesh cut from a grid has point scalars (the voxels)")
        if self.grid is not None and len(self.tets) != 5 * len(self.grid.cells):
            raise VGraphError(f"mesh{where}: a mesh cut from a grid has 5 tetrahedra per cell, got "
                              f"{len(self.tets)} for {len(self.grid.cells)} cells")
        if self.reference_length is not None and not (np.isfinite(self.reference_length)
                                                      and self.reference_length > 0):
            raise VGraphError(f"mesh{where}: reference_length must be positive, got {self.reference_length}")

    # --- geometry -------------------------------------------------------------------------------
    @cached_property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(min corner, max corner) of the points, float64 (x, y, z); once per mesh (renderers frame
        the camera with it every frame)."""
        low, high = self.points.min(axis=0).astype(np.float64), self.points.max(axis=0).astype(np.float64)
        low.flags.writeable = high.flags.writeable = False  # shared by every caller
        return low, high

    @property
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounding box, as Volume geometry calls it (what cameras frame)."""
        return self.bounds

    def tet_volumes(self) -> np.ndarray:
        """Signed volumes of the tetrahedra, float64 (positive: (b - a, c - a, d - a) right-handed)."""
        p = self.points.astype(np.float64)[self.tets]
        return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6.0

    @cached_property
    def mean_edge_length(self) -> float:
        p = self.points.astype(np.float64)[self.tets]
        edges = [p[:, j] - p[:, i] for i in range(4) for j in range(i + 1, 4)]
        return float(np.mean([np.linalg.norm(e, axis=1).mean() for e in edges]))

    @property
    def opacity_length(self) -> float:
        """The world length of one 'sample at rate 1' for transfer-function opacities."""
        return self.reference_length if self.reference_length is not None else self.mean_edge_length

    # --- values ---------------------------------------------------------------------------------
    @cached_property
    def value_range(self) -> tuple[float, float]:
        if self.declared_range is not None:
            return self.declared_range
        finite = self.scalars[np.isfinite(self.scalars)]
        return range_of((finite.min(), finite.max()) if finite.size else None)

    def normalized(self, values=None) -> np.ndarray:
        """Scalars (or ``values``) as normalised intensities, float64, not clamped."""
        lo, hi = self.value_range
        return (np.asarray(self.scalars if values is None else values, dtype=np.float64) - lo) / (hi - lo)

    def tet_scalar_ranges(self) -> tuple[np.ndarray, np.ndarray]:
        """(low, high) normalised scalar of each tetrahedron, float64 (M,): over its four vertices,
        or its one value (per_cell), which is both."""
        values = self.normalized()
        if self.per_cell:
            return values, values
        at_vertices = values[self.tets]
        return at_vertices.min(axis=1), at_vertices.max(axis=1)

    def percentiles(self, percents) -> np.ndarray:
        """Scalar values at ``percents`` (in [0, 100]) of the finite scalars, as np.percentile's
        default (linear) method gives them. The scalars are sorted once per mesh: a percentile TF
        asks for them every frame."""
        ranked = self._sorted_scalars
        p = np.asarray(percents, dtype=np.float64)
        if ranked.size == 0:
            lo, hi = self.value_range
            return lo + p / 100.0 * (hi - lo)
        position = p / 100.0 * (ranked.size - 1)
        below = np.floor(position).astype(np.int64)
        above = np.minimum(below + 1, ranked.size - 1)
        return ranked[below] + (position - below) * (ranked[above] - ranked[below])

    @cached_property
    def _sorted_scalars(self) -> np.ndarray:
        return np.sort(self.scalars[np.isfinite(self.scalars)].astype(np.float64))

    def histogram(self, bins: int = 256) -> tuple[np.ndarray, np.ndarray]:
        """Counts of the finite scalars in equal bins over the value range, and the edges in
        normalised intensity (the TF editor's histogram). Kept per bin count: the GUI's render
        process asks for it every frame (27 ms a frame for tets_bonsai's 1.35 M points)."""
        if bins not in self._histograms:
            values = self.normalized()[np.isfinite(self.scalars)]
            counts = np.histogram(np.clip(values, 0.0, 1.0), bins=bins, range=(0.0, 1.0))[0]
            counts.flags.writeable = False  # shared by every caller
            self._histograms[bins] = counts, np.linspace(0.0, 1.0, bins + 1)
        return self._histograms[bins]

    @cached_property
    def _histograms(self) -> dict:
        return {}

    # --- GPU ------------------------------------------------------------------------------------
    @cached_property
    def vertex_indices(self) -> np.ndarray:
        """(M, 4) int32: each tetrahedron's vertices in the GL vertex buffer (``buffers``): ``tets``
        itself, or with ``per_cell`` 4t .. 4t + 3, since there every tetrahedron has four vertices
        of its own that carry its value."""
        if not self.per_cell:
            return self.tets
        indices = np.arange(4 * len(self.tets), dtype=np.int32).reshape(-1, 4)
        indices.flags.writeable = False
        return indices

    def vertices(self) -> np.ndarray:
        """The GL vertex buffer's content, (K, 4) float32 (x, y, z, normalised scalar): one vertex
        per point, or with ``per_cell`` four per tetrahedron (its corners, each with its value:
        a renderer of point scalars then draws the constant field unchanged)."""
        scalars = self.normalized().astype(np.float32)
        if self.per_cell:
            return np.concatenate([self.points[self.tets].reshape(-1, 3),
                                   np.repeat(scalars, 4)[:, None]], axis=1)
        return np.concatenate([self.points, scalars[:, None]], axis=1)

    def buffers(self, ctx) -> dict:
        """{"points": the vertex buffer (``vertices``), "tets": ``vertex_indices`` as an int32
        index buffer} on ``ctx``, uploaded once per context and released with the mesh or the
        context (vgraph.derived)."""
        return derived.value(self, "mesh buffers", lambda: self._upload(ctx), ctx=ctx)

    def _upload(self, ctx) -> dict:
        vertices = np.ascontiguousarray(self.vertices(), dtype=np.float32)
        return {"points": ctx.buffer(vertices.tobytes()),
                "tets": ctx.buffer(np.ascontiguousarray(self.vertex_indices).tobytes())}
