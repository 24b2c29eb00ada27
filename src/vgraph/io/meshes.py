"""Reading unstructured meshes into a TetMesh (docs/explanations/tetrahedra.md, "Meshes and MeshSource").

    read_mesh(path, array="", declared_range=None, reference_length=None, component="") -> TetMesh

Files are read with meshio (vgraph.io.meshio_reading): VTK legacy (.vtk) and XML (.vtu), Gmsh
(.msh), Medit (.mesh, .meshb), XDMF (.xdmf, .xmf; meshio's reader needs the h5py package), Exodus
II (.e, .exo, .ex2; needs the netCDF4 package; files meshio 5.3 fails on, such as those with one
combined ``vals_nod_var``, are read with netCDF4 itself) and the other formats meshio knows. A
missing optional package is named in the error, with the command that installs it. What is kept:

- the 3D cells: tetrahedra as they are; hexahedra, wedges and pyramids split into 6, 3 and 2
  tetrahedra with matching faces between neighbours (vgraph.tetrahedralize.split_cells: every quad
  face is cut along the diagonal through its smallest vertex index); 10-node tetrahedra split into
  8 linear ones over all their nodes (vgraph.io.mesh_cells); other higher-order cells use their
  corner nodes, with a VGraphWarning saying so. Lines, triangles and quads (a Gmsh file's
  boundary) are ignored; a file without 3D cells is refused.
- one scalar field: ``array`` names it; empty means the first point array, else the first cell
  array, and a VGraphWarning names it and the others. A cell array is constant inside each cell
  (the mesh is ``per_cell``: every tetrahedron of a cell has the cell's value), or with
  ``cell_arrays = "averaged"`` averaged to the points. Of an array with several components
  ``component`` picks one (or the magnitude); a 3-component vector gives its magnitude by
  default, other counts must be chosen (vgraph.io.mesh_arrays).
- the points the tetrahedra use (others, such as a Gmsh file's geometry points, are dropped so the
  bounds are those of the cells). They must be coordinates GL's float32 holds: finite, within
  +-1e15, cells at least 1e-15 across and at least 1e-5 of their distance from the origin
  (vgraph.io.mesh_geometry).

Before meshio reads a byte, the file must be a regular file and the counts its header declares
must fit in the file and in memory (vgraph.io.mesh_counts); whatever meshio raises on damaged input
becomes a MeshFileError.

Every tetrahedron is oriented positively (two vertices swapped where its signed volume is
negative); flat ones (zero volume, e.g. from collapsed cells) are counted and dropped with a
VGraphWarning. Any problem with the input raises MeshFileError naming the file and, where there
is one, the part of it (the cell block, the array).
"""

from __future__ import annotations

import importlib.util
import re
import warnings
from pathlib import Path

import numpy as np

from vgraph.errors import MeshFileError, VGraphError, VGraphWarning
from vgraph.io._common import file_problem
from vgraph.io.mesh_arrays import CELL_PREFIX, choose_array
from vgraph.io.mesh_cells import NODES_PER_CELL, QUADRATIC_TETRA, cell_tetrahedra
from vgraph.io.mesh_counts import check_declared_counts
from vgraph.io.mesh_geometry import check_points
from vgraph.io.meshio_reading import read_meshio
from vgraph.mesh import TetMesh
from vgraph.tetrahedralize import TETS_PER_CELL, orient

# The formats the tests read; meshio reads more (``meshio_extensions``), which are tried too.
MESH_EXTENSIONS = (".vtk", ".vtu", ".msh", ".mesh", ".meshb", ".xdmf", ".xmf", ".e", ".exo", ".ex2")
EXODUS_EXTENSIONS = (".e", ".exo", ".ex2")
FILE_FILTERS = tuple(f"*{e}" for e in MESH_EXTENSIONS)
_CELL_KIND = re.compile(r"^(tetra|hexahedron|wedge|pyramid)(\d*)$")

def meshio_extensions() -> tuple[str, ...]:
    from meshio._helpers import extension_to_filetypes  # imported when used: meshio takes 40 ms
    return tuple(extension_to_filetypes)


def mesh_extension(path: Path) -> str:
    """The longest mesh extension (vgraph's or meshio's) that ``path``'s name ends with, lower
    case; else its suffix."""
    name = path.name.lower()
    known = sorted(set(MESH_EXTENSIONS) | set(meshio_extensions()), key=len, reverse=True)
    return next((e for e in known if name.endswith(e)), path.suffix.lower())


def read_mesh(path, array: str = "", declared_range=None, reference_length=None,
              component: str = "", cell_arrays: str = "constant") -> TetMesh:
    """The mesh in ``path`` as tetrahedra with one scalar per point, or per tetrahedron for a
    cell array (module docstring)."""
    path = Path(path)
    problem = file_problem(path)
    if problem is not None:
        raise MeshFileError(path, "file " + problem)
    check_declared_counts(path, _check_extension(path))
    raw = read_meshio(path)
    points = raw_points(path, raw)
    if points.shape[1] == 2:
        raise MeshFileError(path, "the points are 2D: a 2D mesh has no volume to render", "points")
    blocks = _volume_blocks(path, raw, len(points))
    chosen = choose_array(path, raw, array, component, blocks, len(points), cell_arrays)
    tets, tet_values = _tetrahedra(blocks, points, chosen.values if chosen.per_cell else None)
    if len(tets) == 0:  # hexahedra, wedges or pyramids that repeat a corner split into nothing
        raise MeshFileError(path, "no tetrahedra: every cell repeats a corner (degenerate cells)",
                            "cells")
    used = np.unique(tets)
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    tets = remap[tets]
    check_points(path, points[used], tets, numbers=used)
    points32 = points[used].astype(np.float32)
    tets, flat, kept = orient(points32, tets, with_kept=True)
    if tet_values is not None:
        tet_values = tet_values[kept]
    if flat:
        warnings.warn(VGraphWarning(
            f"{path}: {flat} of {flat + len(tets)} tetrahedra have zero volume (flat or collapsed "
            f"cells) and were dropped"), stacklevel=2)
    if len(tets) == 0:
        raise MeshFileError(path, "every tetrahedron has zero volume: the cells are flat", "cells")
    still_used = np.unique(tets)
    if len(still_used) < len(used):  # points only flat tetrahedra used
        again = np.full(len(used), -1, dtype=np.int64)
        again[still_used] = np.arange(len(still_used))
        tets, points32, used = again[tets], points32[still_used], used[still_used]
    scalars = tet_values if chosen.per_cell else chosen.values[used]
    try:
        return TetMesh(points32, tets, scalars, declared_range=declared_range,
                       reference_length=reference_length, scalar_name=chosen.name,
                       source=str(path), per_cell=chosen.per_cell)
    except VGraphError as error:
        raise MeshFileError(path, str(error)) from None


def _tetrahedra(blocks, points: np.ndarray, cell_values) -> tuple[np.ndarray, np.ndarray | None]:
    """(tetrahedra of every block, and with ``cell_values`` (one array per block) the value of
    the cell each tetrahedron comes from)."""
    tets, values = [], []
    for number, (kind, nodes, _) in enumerate(blocks):
        block_tets, parents = cell_tetrahedra(kind, nodes, points)
        tets.append(block_tets)
        if cell_values is not None:
            values.append(cell_values[number][parents])
    return np.concatenate(tets), (np.concatenate(values) if cell_values is not None else None)


def raw_points(path: Path, raw) -> np.ndarray:
    """meshio's points as float64 (N, 2 or 3), refused when they are not numbers in that shape."""
    points = np.asarray(raw.points)
    if points.dtype.kind not in "uif" or points.ndim != 2 or points.shape[1] not in (2, 3) \
            or len(points) == 0:
        raise MeshFileError(path, f"expected points with 3 coordinates, got an array of "
                                  f"{points.dtype} of shape {points.shape}", "points")
    return points.astype(np.float64, copy=False)


def _check_extension(path: Path) -> str:
    """The file's extension, refused when no reader knows it or its package is missing."""
    extension = mesh_extension(path)
    if extension not in MESH_EXTENSIONS and extension not in meshio_extensions():
        raise MeshFileError(path, f"unknown mesh format {extension or '(no extension)'!r}: "
                                  f"expected one of {', '.join(MESH_EXTENSIONS)} (or another "
                                  f"format meshio reads)")
    if extension in EXODUS_EXTENSIONS and importlib.util.find_spec("netCDF4") is None:
        raise MeshFileError(path, "reading Exodus II files needs the netCDF4 package, which is not "
                                  "installed: pip install netCDF4 (or convert the file to .vtu)")
    return extension


def _node_indices(path: Path, data: np.ndarray, nodes: int, field: str) -> np.ndarray:
    """The first ``nodes`` columns of a cell block as int64 point numbers."""
    if data.ndim != 2 or data.shape[1] < nodes:
        raise MeshFileError(path, f"expected {nodes} point numbers per cell, got an array of "
                                  f"shape {data.shape}", field)
    data = data[:, :nodes]
    if data.dtype.kind == "f" and np.all(np.isfinite(data)) and np.all(data == np.round(data)) \
            and np.abs(data).max() < 2**62:
        data = data.astype(np.int64)
    if data.dtype.kind not in "ui":
        raise MeshFileError(path, f"point numbers must be integers, got {data.dtype} values", field)
    if data.dtype == np.uint64 and data.max() >= 2**63:
        raise MeshFileError(path, f"point number {int(data.max())} is beyond any file's points", field)
    return data.astype(np.int64)


def _volume_blocks(path: Path, raw, point_count: int) -> list[tuple[str, np.ndarray, int]]:
    """[(kind, node indices (n, 4..10) int64, index of the block in raw.cells)] of the 3D cells:
    kind "tetra10" with its 10 nodes, other higher-order cells as their linear kind with their
    corners (a VGraphWarning says so)."""
    blocks, others, cut = [], [], set()
    for number, block in enumerate(raw.cells):
        match = _CELL_KIND.match(block.type)
        if match is None:
            others.append(block.type)
            continue
        kind = block.type if block.type == QUADRATIC_TETRA else match.group(1)
        if kind != block.type:
            cut.add(block.type)
        data = np.asarray(block.data)
        if len(data) == 0:
            continue
        nodes = _node_indices(path, data, NODES_PER_CELL[kind], f"cell block {number} ({block.type})")
        if nodes.min() < 0 or nodes.max() >= point_count:
            raise MeshFileError(path, f"{block.type} cells refer to points {int(nodes.min())} .. "
                                      f"{int(nodes.max())}, but the file has points 0 .. "
                                      f"{point_count - 1}", f"cell block {number} ({block.type})")
        blocks.append((kind, nodes, number))
    if not blocks:
        found = ", ".join(sorted(set(others))) or "no cells at all"
        raise MeshFileError(path, f"no 3D cells (tetrahedra, hexahedra, wedges or pyramids): the "
                                  f"file holds {found}", "cells")
    if cut:
        warnings.warn(VGraphWarning(f"{path}: {', '.join(sorted(cut))} cells are drawn as linear "
                                    f"cells through their corner nodes (their other nodes are not "
                                    f"used; only 10-node tetrahedra are split over all nodes)"),
                      stacklevel=3)
    skipped = {t for t in others if t.startswith("polyhedron") or t.startswith("VTK_")}
    if skipped:
        warnings.warn(VGraphWarning(f"{path}: cells of type {', '.join(sorted(skipped))} are not "
                                    f"supported and were skipped"), stacklevel=3)
    return blocks


__all__ = ["read_mesh", "MeshFileError", "MESH_EXTENSIONS", "FILE_FILTERS", "TETS_PER_CELL",
           "CELL_PREFIX"]
