"""Reading triangle surfaces into a Geometry (SurfaceSource; docs/guide/surfaces.md, "SurfaceSource").

    read_surface(path, array="", component="") -> Geometry

Files are read with meshio (vgraph.io.meshio_reading: one reader at a time, its errors
collected): Wavefront .obj, STL (.stl, ASCII or binary), PLY (.ply), OFF (.off), VTK legacy (.vtk)
and XML (.vtu, .vtp is not read by meshio 5.3) and the other formats meshio knows. What is kept:

- the surface cells: triangles as they are, quads and polygons as fans of triangles from their
  first corner, quadratic triangles and quads by their corner nodes. Lines, vertices and 3D cells
  are left out; a file with no surface cells is refused (one with tetrahedra is pointed to
  MeshSource, which renders volume meshes).
- normals, when the file has them per point (VTK ``Normals``, OBJ ``vn`` matched to points, PLY
  ``nx ny nz``); otherwise the GeometryRenderer computes area-weighted ones.
- colours per point (PLY ``red green blue [alpha]``, 8-bit or float).
- one point scalar: ``array`` names it; empty means the first point array that is neither normals
  nor colours (none: no scalars). Of an array with several components ``component`` picks one or
  the magnitude; a 3-component vector gives its magnitude by default, other counts must be chosen
  (vgraph.io.mesh_arrays, as for MeshSource).
- only the points the triangles use (the bounds, hence the camera's framing, are the surface's),
  held to MeshSource's geometry rules (vgraph.io.mesh_geometry: finite, within +-1e15, triangles
  at least 1e-15 across and 1e-5 of their distance from the origin).

Only regular files are read, and declared counts are checked against the file and memory before
meshio reads it (vgraph.io.mesh_counts), as for meshes. Any problem raises MeshFileError naming the
file and, where there is one, the part of it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vgraph.errors import MeshFileError
from vgraph.geometry import Geometry
from vgraph.io._common import file_problem
from vgraph.io.mesh_arrays import one_value_each
from vgraph.io.mesh_counts import check_declared_counts
from vgraph.io.mesh_geometry import check_points
from vgraph.io.meshes import mesh_extension, meshio_extensions, raw_points
from vgraph.io.meshio_reading import read_meshio

SURFACE_EXTENSIONS = (".obj", ".stl", ".ply", ".off", ".vtk", ".vtu")
FILE_FILTERS = tuple(f"*{e}" for e in SURFACE_EXTENSIONS)
_CORNERS = {"triangle": 3, "triangle6": 3, "triangle7": 3, "quad": 4, "quad8": 4, "quad9": 4}
_VOLUME_CELLS = ("tetra", "hexahedron", "wedge", "pyramid")
_NORMAL_ARRAYS = ("Normals", "normals", "obj:vn")
_COLOR_ARRAYS = ("red", "green", "blue", "alpha", "nx", "ny", "nz")


def read_surface(path, array: str = "", component: str = "") -> Geometry:
    """The triangle surface in ``path`` (module docstring)."""
    path = Path(path)
    problem = file_problem(path)
    if problem is not None:
        raise MeshFileError(path, "file " + problem)
    extension = mesh_extension(path)
    if extension not in SURFACE_EXTENSIONS and extension not in meshio_extensions():
        raise MeshFileError(path, f"unknown surface format {extension or '(no extension)'!r}: "
                                  f"expected one of {', '.join(SURFACE_EXTENSIONS)} (or another "
                                  f"format meshio reads)")
    check_declared_counts(path, extension)
    raw = read_meshio(path)
    points = raw_points(path, raw)
    if points.shape[1] == 2:  # a flat drawing: put it in the z = 0 plane
        points = np.concatenate([points, np.zeros((len(points), 1))], axis=1)
    triangles = _triangles(path, raw, len(points))
    used = np.unique(triangles)
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    check_points(path, points[used], remap[triangles], numbers=used)
    data = {name: np.asarray(values) for name, values in raw.point_data.items()
            if len(np.asarray(values)) == len(points)}
    return Geometry(points[used], remap[triangles],
                    colors=_colors(data, used), normals=_normals(path, data, used),
                    scalars=_scalars(path, data, array, component, used), source=str(path))


def _triangles(path: Path, raw, point_count: int) -> np.ndarray:
    pieces, kinds = [], []
    for block in raw.cells:
        kinds.append(block.type)
        corners = np.asarray(block.data)
        if block.type in _CORNERS:
            corners = corners[:, :_CORNERS[block.type]]
        elif block.type != "polygon" and not block.type.startswith("polygon"):
            continue
        if corners.ndim != 2 or corners.shape[1] < 3:
            continue
        # a fan from the first corner: (0, k, k + 1) for k = 1 .. n - 2 keeps the winding
        pieces += [corners[:, [0, k, k + 1]] for k in range(1, corners.shape[1] - 1)]
    if not pieces:
        found = ", ".join(sorted(set(kinds))) or "no cells at all"
        hint = (": these are volume cells, read them with MeshSource (ProjectedTetrahedra renders them)"
                if any(k.startswith(_VOLUME_CELLS) for k in kinds) else "")
        raise MeshFileError(path, f"no surface cells (triangles, quads or polygons); the file has "
                                  f"{found}{hint}", "cells")
    triangles = np.concatenate(pieces).astype(np.int64)
    if triangles.min() < 0 or triangles.max() >= point_count:
        raise MeshFileError(path, f"cells refer to point {int(triangles.max())} but the file has "
                                  f"{point_count} points", "cells")
    return triangles


def _normals(path: Path, data: dict, used: np.ndarray):
    for name in _NORMAL_ARRAYS:
        if name in data and data[name].shape[1:] == (3,):
            normals = data[name][used].astype(np.float64)
            break
    else:
        if not all(k in data for k in ("nx", "ny", "nz")):
            return None
        normals = np.stack([data[k][used] for k in ("nx", "ny", "nz")], axis=1).astype(np.float64)
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    if not np.all(np.isfinite(lengths)) or np.any(lengths == 0.0):
        return None  # unusable ones: the renderer computes its own from the faces
    return normals / lengths


def _colors(data: dict, used: np.ndarray):
    if not all(k in data for k in ("red", "green", "blue")):
        return None
    channels = [data[k][used] for k in ("red", "green", "blue", "alpha") if k in data]
    scale = 255.0 if np.issubdtype(channels[0].dtype, np.integer) else 1.0
    rgba = np.ones((len(used), 4))
    rgba[:, :len(channels)] = np.stack(channels, axis=1) / scale
    return np.clip(rgba, 0.0, 1.0)


def _scalars(path: Path, data: dict, array: str, component: str, used: np.ndarray):
    candidates = {name: values for name, values in data.items()
                  if name not in _NORMAL_ARRAYS and name not in _COLOR_ARRAYS
                  and np.issubdtype(values.dtype, np.number)}
    if not array:
        if not candidates:
            return None
        array = next(iter(candidates))
    if array not in candidates:
        known = ", ".join(candidates) or "none"
        raise MeshFileError(path, f"no point array {array!r}; the file's point arrays: {known}", "array")
    return one_value_each(path, candidates[array][used], len(used), array, component)
