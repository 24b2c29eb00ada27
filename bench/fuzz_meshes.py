"""Valid mesh files built from scratch with random parameters, the seeds of the ``mesh`` fuzz
target (fuzz_cases.py mutates them and opens them with vgraph.io.meshes.read_mesh).

    case = mesh(random.Random(7))   # a Case with one small tetrahedral mesh file

The mesh is a few cells of a jittered grid: tetrahedra, sometimes hexahedra or wedges beside
them, with a point scalar, sometimes a vector or a 2-component array first, a cell array, NaN
values, coordinates at extreme scales or far from the origin. It is written with meshio in one of
the formats MeshSource reads without optional packages: VTK legacy (ASCII, binary; versions 4.2
and 5.1), VTK XML .vtu (ASCII, binary raw or zlib-compressed), Gmsh .msh (2.2 and 4.1, ASCII and
binary) and Medit .mesh. Text files are marked as the case's header, so that the mutations edit
their lines and numbers as well as their bytes.
"""

from __future__ import annotations

import contextlib
import io
import re
import tempfile
import warnings
from pathlib import Path

import numpy as np

from fuzz_seeds import Case

# (extension, meshio file format, writer options, text file?)
FORMATS = (
    (".vtk", "vtk42", {"binary": False}, True),
    (".vtk", "vtk42", {"binary": True}, False),
    (".vtk", "vtk51", {"binary": False}, True),
    (".vtk", "vtk51", {"binary": True}, False),
    (".vtu", "vtu", {"binary": False}, True),
    (".vtu", "vtu", {"binary": True, "compression": None}, False),
    (".vtu", "vtu", {"binary": True, "compression": "zlib"}, False),
    (".msh", "gmsh22", {"binary": False}, True),
    (".msh", "gmsh22", {"binary": True}, False),
    (".msh", "gmsh", {"binary": False}, True),
    (".msh", "gmsh", {"binary": True}, False),
    (".mesh", "medit", {}, True),
)
# a hexahedron's corners (VTK order) as offsets in a grid of (n + 1)^3 points, and a cube's split
# into five tetrahedra
_HEX = ((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1))
_FIVE = ((0, 1, 3, 4), (1, 2, 3, 6), (1, 4, 5, 6), (3, 4, 6, 7), (1, 3, 4, 6))


def mesh(rng) -> Case:
    extension, file_format, options, text = rng.choice(FORMATS)
    points, cells = _cells(rng)
    points = _placed(rng, points)
    numbers = np.random.default_rng(rng.getrandbits(32))
    point_data, cell_data = {}, {}
    gmsh = file_format.startswith("gmsh")
    if file_format != "medit":  # Medit stores no data arrays
        if rng.random() < 0.3:  # a vector, or (not in Gmsh, which allows 1, 3 or 9) a pair first
            point_data["v"] = numbers.normal(size=(len(points), 3 if gmsh or rng.random() < 0.5 else 2))
        point_data["s"] = numbers.normal(0, 100, size=len(points))
        if rng.random() < 0.2:
            point_data["s"][numbers.integers(len(points))] = rng.choice((np.nan, np.inf, 1e300))
        if rng.random() < 0.3:
            cell_data["c"] = [numbers.normal(size=len(block)) for _, block in cells]
    import meshio
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings(), \
            contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")  # meshio's notes on what a format cannot store
        path = Path(folder) / f"m{extension}"
        meshio.write(path, meshio.Mesh(points, cells, point_data=point_data, cell_data=cell_data),
                     file_format=file_format, **options)
        content = path.read_bytes()
    if gmsh and not options["binary"]:  # meshio 5.3 writes ASCII node data as numpy 2 reprs
        content = re.sub(rb"np\.float64\(([^)]*)\)", rb"\1", content)
    name = f"m{extension}"
    return Case("mesh", {name: content}, name, header=name if text else None)


def _cells(rng) -> tuple[np.ndarray, list[tuple[str, np.ndarray]]]:
    """Points of a jittered grid of 1 to 2 cells per axis and its cells: five tetrahedra per
    cube, or now and then hexahedra, or wedges (each cube's two halves)."""
    n = rng.choice((1, 1, 2))
    numbers = np.random.default_rng(rng.getrandbits(32))
    ijk = np.stack(np.meshgrid(*[np.arange(n + 1)] * 3, indexing="ij"), -1).reshape(-1, 3)
    points = ijk + numbers.uniform(-0.2, 0.2, ijk.shape)

    def index(i, j, k):
        return (i * (n + 1) + j) * (n + 1) + k

    cubes = [[index(i + a, j + b, k + c) for a, b, c in _HEX]
             for i in range(n) for j in range(n) for k in range(n)]
    kind = rng.random()
    if kind < 0.15:
        return points, [("hexahedron", np.array(cubes))]
    if kind < 0.25:
        halves = [[c[0], c[1], c[3], c[4], c[5], c[7]] for c in cubes] + \
                 [[c[1], c[2], c[3], c[5], c[6], c[7]] for c in cubes]
        return points, [("wedge", np.array(halves))]
    return points, [("tetra", np.array([[c[t] for t in tet] for c in cubes for tet in _FIVE]))]


def _placed(rng, points: np.ndarray) -> np.ndarray:
    """The points as they are, or scaled and moved to the edges of what float32 and the GL hold."""
    if rng.random() < 0.7:
        return points
    scale = rng.choice((1e-30, 1e-16, 1e-12, 1e3, 1e13, 1e16, 1e30))
    offset = rng.choice((0.0, 0.0, 1e5, -1e14, 1e15, 1e20))
    return points * scale + offset
