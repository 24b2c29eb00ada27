"""Which values of a mesh file become its point scalar: the array, and of an array with several
components per point (or cell) the component.

    point_scalars(path, raw, array, component, blocks, point_count) -> (float64 (N,), name)
    one_value_each(path, values, count, name, component, per="point") -> float64 (count,)

Arrays (docs/tetrahedra.md, "Meshes and MeshSource"): ``array`` names a point array; empty takes
the first point array that is not the format's bookkeeping (Gmsh tags, Medit references; a Medit
file, which has nothing else, renders its point tags with a warning). ``"cell:NAME"`` takes a
cell array, averaged to the points with a warning.

Components, as ParaView offers them ("Magnitude", "X", "Y", "Z" or the component's number):
``component`` empty takes the one value of a scalar array and the magnitude of a 3-component
vector (a direction in the mesh's space, whose length is what ParaView colours by default); any
other count (2, 4, 6, 9: pairs, complex numbers, tensors) has no scalar that is obviously meant,
so it is refused, naming the array, its count and how to choose. ``"magnitude"`` takes the
Euclidean length of any array, ``"0"`` .. ``"n-1"`` one component, and ``"X"``, ``"Y"``, ``"Z"``
(any case) components 0, 1, 2 of arrays of up to three. A component of a scalar array is refused
(there is nothing to choose).
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from vgraph.errors import MeshFileError, VGraphWarning

CELL_PREFIX = "cell:"
MAGNITUDE = "magnitude"
AXES = "xyz"
# Arrays meshio adds for its own bookkeeping (Gmsh tags, Medit references): never the default.
BOOKKEEPING = re.compile(r"^(gmsh|medit|flac3d|ansys|abaqus|nastran):")


def point_scalars(path: Path, raw, array: str, component: str, blocks,
                  point_count: int) -> tuple[np.ndarray, str]:
    """(scalar per point of the file, float64, and its name) for ``array`` and ``component``.
    ``blocks`` are the 3D cell blocks [(kind, corners, index in raw.cells)] a cell array is
    averaged over."""
    point_names = list(raw.point_data)
    cell_names = list(raw.cell_data)
    if array.startswith(CELL_PREFIX):
        name = array[len(CELL_PREFIX):]
        if name not in raw.cell_data:
            raise MeshFileError(path, f"no cell array {name!r}; {available(point_names, cell_names)}",
                                f"array {array!r}")
        return _cell_to_points(path, raw, name, component, blocks, point_count), array
    if not array:
        array = _default_array(path, raw, point_names, cell_names, point_count)
    if array not in raw.point_data:
        raise MeshFileError(path, f"no point array {array!r}; {available(point_names, cell_names)}",
                            f"array {array!r}")
    return one_value_each(path, np.asarray(raw.point_data[array]), point_count, array, component), array


def _default_array(path: Path, raw, point_names, cell_names, point_count: int) -> str:
    candidates = [n for n in point_names if not BOOKKEEPING.match(n)]
    tags = [n for n in point_names if BOOKKEEPING.match(n)
            and np.asarray(raw.point_data[n]).size == point_count]
    if not candidates and tags:  # a Medit file holds no data, only reference numbers
        warnings.warn(VGraphWarning(f"{path}: no data arrays; rendering the point tags "
                                    f"{tags[0]!r} the format stores"), stacklevel=4)
        candidates = tags
    if not candidates:
        raise MeshFileError(path, f"no point array to render; {available(point_names, cell_names)}"
                                  + (" (ask for a cell array as array = 'cell:NAME')" if cell_names else ""),
                            "array")
    return candidates[0]


def available(point_names, cell_names) -> str:
    listed = [repr(n) for n in point_names] + [repr(CELL_PREFIX + n) for n in cell_names]
    return f"the file has {', '.join(listed)}" if listed else "the file has no arrays"


def one_value_each(path: Path, values: np.ndarray, count: int, name: str, component: str = "",
                   per: str = "point") -> np.ndarray:
    """One float64 value per point (or cell) from ``values``, an array of ``count`` items with one
    or more components each, by ``component`` (module docstring)."""
    if values.dtype.kind not in "uifb":
        raise MeshFileError(path, f"array of {values.dtype} values, not numbers", f"array {name!r}")
    if len(values) != count:
        raise MeshFileError(path, f"{len(values)} values for {count} {per}s", f"array {name!r}")
    values = values.reshape(count, -1).astype(np.float64)
    components = values.shape[1]
    choice = str(component).strip().lower()
    if components == 1:
        if choice:
            raise MeshFileError(path, f"the array has one value per {per}: leave component empty "
                                      f"(got {component!r})", f"array {name!r}")
        return values[:, 0]
    if choice == MAGNITUDE or (not choice and components == 3):
        return np.linalg.norm(values, axis=1)
    if not choice:
        raise MeshFileError(path, f"{components} components per {per}: choose one with the "
                                  f"component property ({_choices(components)}) or 'magnitude'",
                            f"array {name!r}")
    index = _component_index(choice, components)
    if index is None:
        raise MeshFileError(path, f"no component {component!r}: the array has {components} "
                                  f"components per {per} ({_choices(components)}); choose one of "
                                  f"those or 'magnitude'",
                            f"array {name!r}")
    return values[:, index]


def _choices(components: int) -> str:
    axes = [a.upper() for a in AXES[:components]] if components <= len(AXES) else []
    return ", ".join([f"0 .. {components - 1}", *axes])


def _component_index(choice: str, components: int) -> int | None:
    if components <= len(AXES) and choice in AXES[:components]:
        return AXES.index(choice)
    if choice.isdigit() and choice.isascii() and int(choice) < components:
        return int(choice)
    return None


def _cell_to_points(path: Path, raw, name: str, component: str, blocks, point_count: int) -> np.ndarray:
    total = np.zeros(point_count)
    count = np.zeros(point_count)
    for _kind, corners, number in blocks:
        values = one_value_each(path, np.asarray(raw.cell_data[name][number]), len(corners),
                                f"{CELL_PREFIX}{name}", component, per="cell")
        np.add.at(total, corners.reshape(-1), np.repeat(values, corners.shape[1]))
        np.add.at(count, corners.reshape(-1), 1.0)
    warnings.warn(VGraphWarning(
        f"{path}: cell array {name!r} was averaged to the points (each point gets the mean over "
        f"the cells that use it), so the rendering interpolates between cells instead of showing "
        f"one value per cell"), stacklevel=4)
    return np.divide(total, count, out=np.zeros(point_count), where=count > 0)
