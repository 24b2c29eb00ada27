"""The counts a mesh file declares, checked before meshio reads it: meshio allocates what a header
says (``POINTS 100000000000000 float`` in a 150-byte file asked for 2.4 PB), so a count the file
cannot hold is refused as damaged, and one the memory cannot hold is refused with the sizes.

    check_declared_counts(path, extension)   # MeshFileError naming the declaration, or nothing

The declarations are found with regular expressions over the file (mapped, not read into
memory): VTK legacy ``POINTS``, ``CELLS``, ``CELL_TYPES``, ``DIMENSIONS``; VTK XML
``NumberOfPoints`` and ``NumberOfCells``; Gmsh ``$Nodes`` and ``$Elements`` (version 2, and
version 4 in ASCII: a binary version 4 file writes its counts in binary) and the tag counts that
open ``$NodeData``/``$ElementData`` blocks; Medit ``Vertices``,
``Tetrahedra``, ``Hexahedra`` ... (ASCII ``.mesh``). Other formats are left to meshio and the
memory errors it raises.

- Against the file: a declared count needs at least so many bytes: in ASCII one digit and one
  separator per number, in binary the numbers' size (a lower bound: real files hold more).
  Compressed formats (XML with zlib, DIMENSIONS of structured points) are checked against memory
  only.
- None at all: a file that declares zero points or zero cells (and no other number of them) is
  refused as having none, before meshio fails on the empty arrays in its own words.
- Against memory (vgraph.io._common.check_memory, under RLIMIT_AS too): the points and cells as
  meshio holds them, POINT_BYTES a point (three float64) and CELL_BYTES a cell (eight int64
  corners).
"""

from __future__ import annotations

import mmap
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vgraph.errors import MeshFileError, VolumeFileError
from vgraph.memory import check_memory, format_bytes

POINT_BYTES = 24
CELL_BYTES = 64
# Gmsh node tags: at most this many per byte of the file, and always up to MIN_TAG_LIMIT
MAX_TAGS_PER_BYTE = 8
MIN_TAG_LIMIT = 2**24
_COUNT = rb"(\d{1,30})(?!\d)"  # longer digit strings are no count anyone can mean: meshio's problem
_VTK_TYPES = {b"bit": 1, b"char": 1, b"unsigned_char": 1, b"short": 2, b"unsigned_short": 2,
              b"int": 4, b"unsigned_int": 4, b"long": 8, b"unsigned_long": 8, b"float": 4,
              b"double": 8, b"vtktypeint64": 8, b"vtktypeuint64": 8, b"vtkidtype": 4}
# Medit keywords and the numbers of one item of each (corners and a reference; 2D vertices have 3)
_MEDIT_NUMBERS = {b"Vertices": 3, b"Edges": 3, b"Triangles": 4, b"Quadrilaterals": 5,
                  b"Tetrahedra": 5, b"Prisms": 7, b"Pyramids": 6, b"Hexahedra": 9}


@dataclass(frozen=True)
class Declaration:
    field: str         # the declaration's name in the file, for the message
    count: int         # items declared
    what: str          # "points", "cells", "numbers"
    file_bytes: int    # at least this many bytes must follow in the file (0: not checked)
    points: int = 0    # what it adds to the memory estimate
    cells: int = 0
    table_bytes: int = 0  # another allocation meshio makes from it
    reason: str = ""   # the refusal when file_bytes are not there, if not the usual one


def check_declared_counts(path: Path, extension: str) -> None:
    """Refuse a file whose declared counts it cannot hold, or the memory cannot (module docstring)."""
    scan = _SCANNERS.get(extension)
    if scan is None:
        return
    size = path.stat().st_size
    if size == 0:
        return  # meshio says what is wrong with an empty file
    with open(path, "rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as view:
        declarations = scan(view)
    for d in declarations:
        if d.file_bytes > size:
            raise MeshFileError(path, d.reason or f"the file declares {d.count} {d.what} (at least "
                                                  f"{format_bytes(d.file_bytes)}) but holds only "
                                                  f"{size} bytes: damaged or truncated", d.field)
    for what, kinds in (("points", ("points", "vertices", "grid points")), ("cells", ("cells",))):
        declared = [d for d in declarations if d.what in kinds]
        if declared and all(d.count == 0 for d in declared):
            raise MeshFileError(path, f"no {what}: the file declares {declared[0].field} 0", what)
    points = sum(d.points for d in declarations)
    cells = sum(d.cells for d in declarations)
    tables = sum(d.table_bytes for d in declarations)
    if points or cells or tables:
        field = next(d.field for d in declarations if d.points or d.cells or d.table_bytes)
        try:
            check_memory(path, POINT_BYTES * points + CELL_BYTES * cells + tables, field)
        except VolumeFileError as error:
            raise MeshFileError(path, f"{error.reason} ({points} points and {cells} cells"
                                      + (f", tables of {format_bytes(tables)}" if tables else "")
                                      + ")", field) from None


def _numbers(count: int, binary: bool, itemsize: int = 4) -> int:
    """The fewest bytes ``count`` numbers take: the item size each in binary, a digit and a
    separator each in ASCII."""
    return count * itemsize if binary else max(2 * count - 1, 0)


def _vtk_legacy(view) -> list[Declaration]:
    head = view[:4096]
    kind = re.search(rb"^(ASCII|BINARY)[ \t\r]*$", head, re.M | re.I)
    binary = bool(kind) and kind.group(1).upper() == b"BINARY"
    found = []
    for match in re.finditer(rb"^POINTS[ \t]+" + _COUNT + rb"[ \t]+(\w+)", view, re.M):
        n, size = int(match.group(1)), _VTK_TYPES.get(match.group(2).lower(), 1)
        found.append(Declaration("POINTS", n, "points", _numbers(3 * n, binary, size), points=n))
    for match in re.finditer(rb"^CELLS[ \t]+" + _COUNT + rb"[ \t]+" + _COUNT, view, re.M):
        n, numbers = int(match.group(1)), max(int(match.group(1)), int(match.group(2)))
        found.append(Declaration("CELLS", n, "cells", _numbers(numbers, binary), cells=n))
    for match in re.finditer(rb"^CELL_TYPES[ \t]+" + _COUNT, view, re.M):
        n = int(match.group(1))
        found.append(Declaration("CELL_TYPES", n, "cell types", _numbers(n, binary)))
    for match in re.finditer(rb"^DIMENSIONS[ \t]+" + _COUNT + rb"[ \t]+" + _COUNT + rb"[ \t]+" + _COUNT,
                             view, re.M):
        nx, ny, nz = (int(g) for g in match.groups())
        found.append(Declaration("DIMENSIONS", nx * ny * nz, "grid points", 0, points=nx * ny * nz,
                                 cells=max(nx - 1, 1) * max(ny - 1, 1) * max(nz - 1, 1)))
    return found


def _vtk_xml(view) -> list[Declaration]:
    found = [Declaration("NumberOfPoints", int(m.group(1)), "points", 0, points=int(m.group(1)))
             for m in re.finditer(rb"NumberOfPoints=\"" + _COUNT + rb"\"", view)]
    found += [Declaration("NumberOfCells", int(m.group(1)), "cells", 0, cells=int(m.group(1)))
              for m in re.finditer(rb"NumberOfCells=\"" + _COUNT + rb"\"", view)]
    return found


def _gmsh(view) -> list[Declaration]:
    header = re.search(rb"\$MeshFormat[ \t\r]*\n[ \t]*([\d.]+)[ \t]+(\d)(?:[ \t]+(\d{1,2}))?",
                       view[:4096])
    if header is None:
        return []
    version, binary = header.group(1), header.group(2) != b"0"
    count_at = 0 if version.startswith(b"2") else 1  # version 4: blocks, then the total
    found = []
    # version 4 binary writes its counts in binary (its node tags are looked at below)
    text_counts = () if binary and not version.startswith(b"2") else \
        ((b"Nodes", "points", 8), (b"Elements", "cells", 4))
    for section, what, per_item in text_counts:
        pattern = rb"^\$" + section + rb"[ \t\r]*\n[ \t]*" + _COUNT + rb"(?:[ \t]+" + _COUNT + rb")?"
        for match in re.finditer(pattern, view, re.M):
            if match.group(count_at + 1) is None:
                continue
            n = int(match.group(count_at + 1))
            found.append(Declaration(f"${section.decode()}", n, what, per_item * n,
                                     points=n if what == "points" else 0,
                                     cells=n if what == "cells" else 0))
    nodes = re.search(rb"^\$Nodes[ \t\r]*\n", view, re.M)
    if nodes is not None:
        found += _gmsh_node_tags(view, nodes.end(), version, binary, int(header.group(3) or 8))
    for match in re.finditer(rb"^\$(NodeData|ElementData|ElementNodeData)[ \t\r]*\n", view, re.M):
        found += _gmsh_data_tags(view, match.end(), f"${match.group(1).decode()}")
    return found


def _gmsh_node_tags(view, at: int, version: bytes, binary: bool, data_size: int) -> list[Declaration]:
    """The largest node tag of a Gmsh file: meshio maps tags to points with a table as long as the
    largest tag (8 bytes an entry in version 4, filled: a 782-byte file with one tag flipped to
    2^27 took 1 GiB). Refused beyond MAX_TAGS_PER_BYTE per byte of the file (and 2^24 in any file);
    the table counts against memory. Found where the tags are: version 2 ASCII, the first number
    of each node line; version 4 ASCII, the lines holding one integer; version 4 binary, each
    block's tags (version 2 binary, where meshio insists on tags 1 .. n, is not looked at)."""
    end = view.find(b"$EndNodes", at)
    end = len(view) if end < 0 else end
    if not binary:
        line = rb"^[ \t]*(\d{1,30})[ \t]" if version.startswith(b"2") else rb"^[ \t]*(\d{1,30})[ \t\r]*$"
        largest = max((int(m.group(1)) for m in re.finditer(line, view[at:end], re.M)), default=0)
    elif version.startswith(b"4") and data_size in (4, 8):
        largest = _largest_binary_tag(view, at, end, np.dtype(f"<u{data_size}"))
    else:
        return []
    limit = max(MIN_TAG_LIMIT, MAX_TAGS_PER_BYTE * len(view))
    reason = (f"node tag {largest} is beyond what a file of {len(view)} bytes numbers (up to "
              f"{limit} here): damaged (meshio builds a table as long as the largest tag)")
    return [Declaration("$Nodes", largest, "node tags", 0 if largest <= limit else len(view) + 1,
                        table_bytes=8 * largest, reason=reason)]


def _largest_binary_tag(view, at: int, end: int, size_t: np.dtype) -> int:
    """The largest tag of the version 4 binary node blocks between ``at`` and ``end``: a header of
    4 size_t, then per block 3 int32 (dimension, entity, parametric), a size_t count, the tags
    (size_t) and 3 float64 coordinates a node (more when parametric: meshio refuses those)."""
    if end - at < 4 * size_t.itemsize:
        return 0
    blocks = int(np.frombuffer(view, size_t, 1, at)[0])
    at += 4 * size_t.itemsize
    largest = 0
    for _ in range(blocks):
        if end - at < 12 + size_t.itemsize:
            break
        count = int(np.frombuffer(view, size_t, 1, at + 12)[0])
        at += 12 + size_t.itemsize
        available = (end - at) // size_t.itemsize
        tags = np.frombuffer(view, size_t, min(count, available), at)
        if tags.size:
            largest = max(largest, int(tags.max()))
        if count > available:
            break
        at += count * (size_t.itemsize + 24)
    return largest


def _gmsh_data_tags(view, at: int, field: str) -> list[Declaration]:
    """The string and real tag counts that open a Gmsh data block: meshio reads that many lines one
    by one without looking whether the file has them (2147483648 string tags hung it). Each tag
    is a line, so a count needs at least as many bytes. Only the first few lines are looked at."""
    found = []
    for what in ("string tags", "real tags"):
        end = view.find(b"\n", at)
        end = len(view) if end < 0 else end
        line = bytes(view[at:min(end, at + 64)]).strip()
        if not (line.isdigit() and len(line) <= 30):
            break  # not a count: meshio says what is wrong
        n = int(line)
        found.append(Declaration(field, n, what, n))
        if n > 16:
            break  # the file holds them or was refused; the next count is not worth the walk
        at = end + 1
        for _ in range(n):
            at = view.find(b"\n", at) + 1
            if at <= 0:
                return found
    return found


def _medit(view) -> list[Declaration]:
    found = []
    keywords = b"|".join(_MEDIT_NUMBERS)
    for match in re.finditer(rb"^[ \t]*(" + keywords + rb")[ \t\r\n]+" + _COUNT, view, re.M):
        keyword, n = match.group(1), int(match.group(2))
        points = n if keyword == b"Vertices" else 0
        found.append(Declaration(keyword.decode(), n, "vertices" if points else "cells",
                                 _numbers(_MEDIT_NUMBERS[keyword] * n, False),
                                 points=points, cells=0 if points else n))
    return found


_SCANNERS = {".vtk": _vtk_legacy, ".vtu": _vtk_xml, ".msh": _gmsh, ".mesh": _medit}
