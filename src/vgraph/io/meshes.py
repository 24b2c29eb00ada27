"""Reading unstructured meshes into a TetMesh (docs/tetrahedra.md, "Meshes and MeshSource").

    read_mesh(path, array="", declared_range=None, reference_length=None, component="") -> TetMesh

Files are read with meshio: VTK legacy (.vtk) and XML (.vtu), Gmsh (.msh), Medit (.mesh,
.meshb), XDMF (.xdmf, .xmf; meshio's reader needs the h5py package), Exodus II (.e, .exo, .ex2;
needs the netCDF4 package; files meshio 5.3 fails on, such as those with one combined
``vals_nod_var``, are read by ``_read_exodus``) and the other formats meshio knows. A missing
optional package is named in the error, with the command that installs it. What is kept:

- the 3D cells: tetrahedra as they are; hexahedra, wedges and pyramids split into 6, 3 and 2
  tetrahedra with matching faces between neighbours (vgraph.tetrahedralize.split_cells: every quad
  face is cut along the diagonal through its smallest vertex index); quadratic and higher-order
  cells use their corner nodes. Lines, triangles and quads (a Gmsh file's boundary) are ignored;
  a file without 3D cells is refused.
- one point scalar: ``array`` names it; empty means the first point array. ``"cell:NAME"`` takes
  a cell array instead, averaged to the points (each point gets the mean over the 3D cells that
  use it), with a VGraphWarning saying so. Of an array with several components ``component``
  picks one (or the magnitude); a 3-component vector gives its magnitude by default, other counts
  must be chosen (vgraph.io.mesh_arrays).
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

import contextlib
import importlib.util
import io
import re
import warnings
from pathlib import Path

import numpy as np

from vgraph.errors import MeshFileError, VGraphError, VGraphWarning
from vgraph.io._common import file_problem
from vgraph.io.mesh_arrays import CELL_PREFIX, point_scalars
from vgraph.io.mesh_counts import check_declared_counts
from vgraph.io.mesh_geometry import check_points
from vgraph.mesh import TetMesh
from vgraph.tetrahedralize import TETS_PER_CELL, orient, split_cells

# The formats the tests read; meshio reads more (``meshio_extensions``), which are tried too.
MESH_EXTENSIONS = (".vtk", ".vtu", ".msh", ".mesh", ".meshb", ".xdmf", ".xmf", ".e", ".exo", ".ex2")
EXODUS_EXTENSIONS = (".e", ".exo", ".ex2")
FILE_FILTERS = tuple(f"*{e}" for e in MESH_EXTENSIONS)
_CELL_KIND = re.compile(r"^(tetra|hexahedron|wedge|pyramid)(\d*)$")
_CORNER_COUNT = {"tetra": 4, "hexahedron": 8, "wedge": 6, "pyramid": 5}

def meshio_extensions() -> tuple[str, ...]:
    from meshio._helpers import extension_to_filetypes
    return tuple(extension_to_filetypes)


def _extension(path: Path) -> str:
    name = path.name.lower()
    known = sorted(set(MESH_EXTENSIONS) | set(meshio_extensions()), key=len, reverse=True)
    return next((e for e in known if name.endswith(e)), path.suffix.lower())


def read_mesh(path, array: str = "", declared_range=None, reference_length=None,
              component: str = "") -> TetMesh:
    """The mesh in ``path`` as tetrahedra with one point scalar (module docstring)."""
    path = Path(path)
    problem = file_problem(path)
    if problem is not None:
        raise MeshFileError(path, "file " + problem)
    check_declared_counts(path, _check_extension(path))
    raw = _read_meshio(path)
    points = raw_points(path, raw)
    if points.shape[1] == 2:
        raise MeshFileError(path, "the points are 2D: a 2D mesh has no volume to render", "points")
    blocks = _volume_blocks(path, raw, len(points))
    scalars, name = point_scalars(path, raw, array, component, blocks, len(points))
    tets = np.concatenate([split_cells(kind, corners) for kind, corners, _ in blocks])
    used = np.unique(tets)
    remap = np.full(len(points), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    tets = remap[tets]
    check_points(path, points[used], tets, numbers=used)
    points32 = points[used].astype(np.float32)
    tets, flat = orient(points32, tets)
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
    try:
        return TetMesh(points32, tets, scalars[used], declared_range=declared_range,
                       reference_length=reference_length, scalar_name=name, source=str(path))
    except VGraphError as error:
        raise MeshFileError(path, str(error)) from None


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
    extension = _extension(path)
    if extension not in MESH_EXTENSIONS and extension not in meshio_extensions():
        raise MeshFileError(path, f"unknown mesh format {extension or '(no extension)'!r}: "
                                  f"expected one of {', '.join(MESH_EXTENSIONS)} (or another "
                                  f"format meshio reads)")
    if extension in EXODUS_EXTENSIONS and importlib.util.find_spec("netCDF4") is None:
        raise MeshFileError(path, "reading Exodus II files needs the netCDF4 package, which is not "
                                  "installed: pip install netCDF4 (or convert the file to .vtu)")
    return extension


def _read_meshio(path: Path):
    """meshio's reader(s) for the extension, called one by one: meshio.read itself prints a
    failed reader's error and calls sys.exit."""
    from meshio._helpers import _filetypes_from_path, reader_map
    reasons = []
    for file_format in _filetypes_from_path(path):
        try:
            with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
                warnings.simplefilter("ignore")  # meshio warns about what it skips; we report ourselves
                return reader_map[file_format](str(path))
        except MemoryError:
            raise MeshFileError(path, "too large for memory (or a damaged header asks for an "
                                      "absurd size)") from None
        except ModuleNotFoundError as error:
            raise MeshFileError(path, f"reading {file_format} files needs the {error.name} package, "
                                      f"which is not installed: pip install {error.name}") from None
        except (Exception, SystemExit) as error:  # meshio and numpy raise anything on damaged input
            reasons.append(f"as {file_format}: {type(error).__name__}: "
                           f"{str(error).strip() or '(no message)'}")
            if file_format == "exodus":
                try:
                    return _read_exodus(path)
                except MeshFileError:
                    raise
                except Exception as second:  # noqa: BLE001  (damaged input, as above)
                    reasons.append(f"as Exodus II with netCDF4: {type(second).__name__}: "
                                   f"{str(second).strip() or '(no message)'}")
    raise MeshFileError(path, f"cannot read the mesh (damaged, truncated or not this format): "
                              f"{'; '.join(reasons)}")


def _read_exodus(path: Path):
    """Points, cells and the first time step's nodal variables of an Exodus II file, read with
    netCDF4. meshio 5.3's reader expects one ``vals_nod_var<i>`` per variable and fails with a
    KeyError on files that hold them all in one ``vals_nod_var`` (time, variable, node), as the
    shared disk_out_ref.ex2 does."""
    import meshio
    import netCDF4
    from meshio.exodus._exodus import categorize, exodus_to_meshio_type

    def text(variable) -> list[str]:
        variable.set_auto_mask(False)
        return [b"".join(row).decode("utf-8", "replace").strip() for row in variable[:]]

    with netCDF4.Dataset(path) as nc:
        var = nc.variables
        if "coord" in var:
            points = np.asarray(var["coord"][:]).T
        else:
            points = np.stack([np.asarray(var[n][:]) for n in ("coordx", "coordy", "coordz") if n in var],
                              axis=1)
        cells = []
        for key in sorted((k for k in var if k.startswith("connect")), key=lambda k: int(k[7:] or 0)):
            kind = exodus_to_meshio_type.get(var[key].elem_type.upper())
            if kind is None:
                raise MeshFileError(path, f"unknown element type {var[key].elem_type!r}", key)
            cells.append((kind, np.asarray(var[key][:]).astype(np.int64) - 1))  # 1-based
        names = text(var["name_nod_var"]) if "name_nod_var" in var else []
        steps = len(var["time_whole"]) if "time_whole" in var else 1
        nodal = {}
        for i, name in enumerate(names):
            if "vals_nod_var" in var:
                nodal[name] = np.asarray(var["vals_nod_var"][0, i], dtype=np.float64)
            elif f"vals_nod_var{i + 1}" in var:
                nodal[name] = np.asarray(var[f"vals_nod_var{i + 1}"][0], dtype=np.float64)
    if steps > 1:
        warnings.warn(VGraphWarning(f"{path}: the file holds {steps} time steps; the first is read"),
                      stacklevel=4)
    present = [n for n in names if n in nodal]
    single, double, triple = categorize(present)
    point_data = {name: nodal[present[i]] for name, i in single}
    point_data |= {name: np.column_stack([nodal[present[i]] for i in group])
                   for name, *group in (*double, *triple)}
    return meshio.Mesh(points, cells, point_data=point_data)


def _volume_blocks(path: Path, raw, point_count: int) -> list[tuple[str, np.ndarray, int]]:
    """[(kind, corner indices (n, 4..8) int64, index of the block in raw.cells)] of the 3D cells."""
    blocks, others = [], []
    for number, block in enumerate(raw.cells):
        match = _CELL_KIND.match(block.type)
        if match is None:
            others.append(block.type)
            continue
        kind = match.group(1)
        data = np.asarray(block.data)
        if len(data) == 0:
            continue
        corners = data[:, :_CORNER_COUNT[kind]].astype(np.int64)
        if corners.min() < 0 or corners.max() >= point_count:
            raise MeshFileError(path, f"{block.type} cells refer to points {int(corners.min())} .. "
                                      f"{int(corners.max())}, but the file has points 0 .. "
                                      f"{point_count - 1}", f"cell block {number} ({block.type})")
        blocks.append((kind, corners, number))
    if not blocks:
        found = ", ".join(sorted(set(others))) or "no cells at all"
        raise MeshFileError(path, f"no 3D cells (tetrahedra, hexahedra, wedges or pyramids): the "
                                  f"file holds {found}", "cells")
    skipped = {t for t in others if t.startswith("polyhedron") or t.startswith("VTK_")}
    if skipped:
        warnings.warn(VGraphWarning(f"{path}: cells of type {', '.join(sorted(skipped))} are not "
                                    f"supported and were skipped"), stacklevel=3)
    return blocks


__all__ = ["read_mesh", "MeshFileError", "MESH_EXTENSIONS", "FILE_FILTERS", "TETS_PER_CELL",
           "CELL_PREFIX"]
