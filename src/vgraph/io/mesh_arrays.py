"""Which values of a mesh file are rendered: the array, point or cell, and of an array with
several components per point (or cell) the component.

    choose_array(path, raw, array, component, blocks, point_count, cell_arrays="constant")
        -> Chosen(name, per_cell, values)
    one_value_each(path, values, count, name, component, per="point") -> float64 (count,)

Arrays (docs/explanations/tetrahedra.md, "Meshes and MeshSource"): ``array`` empty takes the first point array
that is not the format's bookkeeping (Gmsh tags, Medit references), else the first cell array,
and says which with a VGraphWarning naming the others (one line; a file with several arrays
renders one of them, which should not go unnoticed); a file with no data arrays but tags renders
its tags with a warning (a Medit file has nothing else), one with nothing is refused. ``"NAME"``
names a point array, or a cell array when no point array has that name; ``"cell:NAME"`` names a
cell array. A name the file does not have is refused, listing the point and cell arrays there are
(a MeshFileError whose field is "array"; MeshSource names its ``array`` property).

A cell array is one value per cell. ``cell_arrays = "constant"`` (the default) keeps it so: the
mesh is ``per_cell`` (vgraph.mesh.TetMesh), constant inside each cell and each of its tetrahedra,
which is what the file says. ``"averaged"`` gives each point the mean over the 3D cells that use
it, a smooth field that blends neighbouring cells, for when that is wanted.

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
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vgraph.errors import MeshFileError, VGraphWarning

CELL_PREFIX = "cell:"
MAGNITUDE = "magnitude"
AXES = "xyz"
CELL_ARRAYS = ("constant", "averaged")
# Arrays meshio adds for its own bookkeeping (Gmsh tags, Medit references): never the default.
BOOKKEEPING = re.compile(r"^(gmsh|medit|flac3d|ansys|abaqus|nastran):")


@dataclass
class Chosen:
    """The array to render: ``name`` as the mesh reports it (``"T"``, or ``"cell:S"`` for a cell
    array), ``per_cell`` whether ``values`` are one per cell, and ``values``: float64 (N,) per
    point, or per cell one float64 array for each block of ``blocks``, in their order."""
    name: str
    per_cell: bool
    values: np.ndarray | list[np.ndarray]


def choose_array(path: Path, raw, array: str, component: str, blocks, point_count: int,
                 cell_arrays: str = "constant") -> Chosen:
    """The values to render for ``array`` and ``component`` (module docstring). ``blocks`` are the
    3D cell blocks [(kind, nodes, index in raw.cells)] a cell array is taken from."""
    point_names, cell_names = list(raw.point_data), list(raw.cell_data)
    if cell_arrays not in CELL_ARRAYS:
        raise MeshFileError(path, f"cell_arrays must be one of {', '.join(CELL_ARRAYS)}, got "
                                  f"{cell_arrays!r}", "cell_arrays")
    automatic = not array
    if automatic:
        array = _default_array(path, raw, point_names, cell_names, point_count)
    if array.startswith(CELL_PREFIX) or (array not in raw.point_data and array in raw.cell_data):
        name = array.removeprefix(CELL_PREFIX)
        if name not in raw.cell_data:
            raise MeshFileError(path, f"no cell array {name!r}; {available(point_names, cell_names)}",
                                "array")
        per_block = [one_value_each(path, np.asarray(raw.cell_data[name][number]), len(nodes),
                                    CELL_PREFIX + name, component, per="cell")
                     for _kind, nodes, number in blocks]
        chosen = Chosen(CELL_PREFIX + name, True, per_block)
        if cell_arrays == "averaged":
            chosen = Chosen(chosen.name, False, _cell_to_points(per_block, blocks, point_count))
    elif array in raw.point_data:
        chosen = Chosen(array, False, one_value_each(path, np.asarray(raw.point_data[array]),
                                                     point_count, array, component))
    else:
        raise MeshFileError(path, f"no array {array!r}; {available(point_names, cell_names)}",
                            "array")
    if automatic and not BOOKKEEPING.match(chosen.name.removeprefix(CELL_PREFIX)):
        _say_which(path, chosen, point_names, cell_names)
    return chosen


def _default_array(path: Path, raw, point_names, cell_names, point_count: int) -> str:
    """The first point array, else the first cell array, that is data; else the format's tags."""
    data = [n for n in point_names if not BOOKKEEPING.match(n)] + \
        [CELL_PREFIX + n for n in cell_names if not BOOKKEEPING.match(n)]
    if data:
        return data[0]
    tags = [n for n in point_names if np.asarray(raw.point_data[n]).size == point_count] + \
        [CELL_PREFIX + n for n in cell_names if all(np.asarray(v).ndim == 1 for v in raw.cell_data[n])]
    if tags:  # a Medit file holds no data, only reference numbers
        kind = "cell" if tags[0].startswith(CELL_PREFIX) else "point"
        warnings.warn(VGraphWarning(f"{path}: no data arrays; rendering the {kind} tags "
                                    f"{tags[0].removeprefix(CELL_PREFIX)!r} the format stores"),
                      stacklevel=5)
        return tags[0]
    raise MeshFileError(path, f"no array to render: {available(point_names, cell_names)}", "array")


def _say_which(path: Path, chosen: Chosen, point_names, cell_names) -> None:
    point_others = [n for n in point_names if n != chosen.name]
    cell_others = [n for n in cell_names if CELL_PREFIX + n != chosen.name]
    kind = "cell array (constant in each cell)" if chosen.per_cell else \
        "cell array (averaged to the points)" if chosen.name.startswith(CELL_PREFIX) else "point array"
    others = (f"; {available(point_others, cell_others, also=True)} (choose with the MeshSource's "
              f"array property)") if point_others or cell_others else ", its only array"
    warnings.warn(VGraphWarning(f"{path.name}: rendering the {kind} "
                                f"{chosen.name.removeprefix(CELL_PREFIX)!r}{others}"), stacklevel=4)


def available(point_names, cell_names, also: bool = False) -> str:
    """What the file has, e.g. "the file has point arrays 'T', 'V'; cell arrays 'S'"."""
    parts = [f"{kind} array{'s' if len(names) > 1 else ''} {', '.join(map(repr, names))}"
             for kind, names in (("point", point_names), ("cell", cell_names)) if names]
    if not parts:
        return "the file has no arrays"
    return f"the file {'also ' if also else ''}has {'; '.join(parts)}"


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


def _cell_to_points(per_block: list[np.ndarray], blocks, point_count: int) -> np.ndarray:
    """Each point's mean of the cell values over the 3D cells that use it (0 where none does)."""
    total = np.zeros(point_count)
    count = np.zeros(point_count)
    for values, (_kind, nodes, _number) in zip(per_block, blocks):
        np.add.at(total, nodes.reshape(-1), np.repeat(values, nodes.shape[1]))
        np.add.at(count, nodes.reshape(-1), 1.0)
    return np.divide(total, count, out=np.zeros(point_count), where=count > 0)
