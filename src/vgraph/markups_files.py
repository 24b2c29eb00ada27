"""Markups to and from files: CSV, JSON, and 3D Slicer's markups JSON (issue 36).

    write_markups(markups, "ruler.csv" | "ruler.json" | "ruler.mrk.json")
    markups = read_markups(path)

The format is the file name's: ``.mrk.json`` is Slicer's, other ``.json`` ours, ``.csv`` CSV.
Every write is atomic (vgraph.atomic); every problem of a file read is a ``MarkupsFileError``
naming the file and, where it has one, the place in it (``markups[1].controlPoints[0].position``).

- CSV: a header ``name,kind,point,x,y,z`` then one row per point (``point`` counting from 0), a
  markup's rows together in order; coordinates as Python's repr (every float64 digit, exact
  read-back). Names are quoted by the csv module where they must be.
- JSON (ours): ``{"markups": [{"name", "kind", "points": [[x, y, z], ...], "visible"}]}``, the
  MarkupsProperty's form in a network file.
- Slicer's markups JSON (https://github.com/Slicer/Slicer, Modules/Loadable/Markups/Resources/Schema,
  markups-schema-v1.0.3.json): ``{"@schema": ..., "markups": [{"type", "coordinateSystem",
  "controlPoints": [{"label", "position"}, ...]}, ...]}``. Types: Fiducial (our points), Line
  (ruler), Angle (angle), ClosedCurve (closed_curve); other types (Curve, Plane, ROI) are
  refused by name. ``coordinateSystem`` LPS (Slicer's default) has x and y negated to our RAS;
  RAS is taken as it is. A markup's name is its ``name`` where the file has one, else the file's
  name (without .mrk.json) and, for several markups, its number. We write LPS, as Slicer does.
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

from pydantic import ValidationError

from vgraph.atomic import write_text_atomic
from vgraph.errors import VGraphError
from vgraph.file_names import shown
from vgraph.json_limits import MAX_NESTING, nesting_depth
from vgraph.markups import Markup, Markups

SLICER_SCHEMA = ("https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/Markups/"
                 "Resources/Schema/markups-schema-v1.0.3.json#")
SLICER_TYPES = {"Fiducial": "points", "Line": "ruler", "Angle": "angle", "ClosedCurve": "closed_curve"}
OUR_KINDS = {kind: slicer for slicer, kind in SLICER_TYPES.items()}
CSV_HEADER = ["name", "kind", "point", "x", "y", "z"]
MAX_FILE_BYTES = 64 * 1024 * 1024  # a markups file holds points, not volumes


class MarkupsFileError(VGraphError):
    def __init__(self, path, where: str, reason: str):
        self.path, self.where, self.reason = str(path), where, reason
        super().__init__(f"{self.path}: {where + ': ' if where else ''}{reason}")


def file_format(path) -> str:
    name = Path(path).name.lower()
    if name.endswith(".mrk.json"):
        return "slicer"
    if name.endswith(".json"):
        return "json"
    if name.endswith(".csv"):
        return "csv"
    raise MarkupsFileError(path, "", "unknown markups format: the name must end in .csv, .json or .mrk.json")


# --- writing ------------------------------------------------------------------------------------
def write_markups(markups: Markups, path) -> None:
    """Write ``markups`` in the format of ``path``'s name (module docstring), atomically."""
    writer = {"csv": csv_text, "json": json_text, "slicer": slicer_text}[file_format(path)]
    write_text_atomic(path, writer(markups))


def csv_text(markups: Markups) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(CSV_HEADER)
    for markup in markups.markups:
        for index, (x, y, z) in enumerate(markup.points):
            writer.writerow([markup.name, markup.kind, index, repr(x), repr(y), repr(z)])
    return buffer.getvalue()


def json_text(markups: Markups) -> str:
    return json.dumps(markups.model_dump(mode="json"), indent=1) + "\n"


def slicer_text(markups: Markups) -> str:
    document = {"@schema": SLICER_SCHEMA, "markups": [
        {"type": OUR_KINDS[m.kind], "name": m.name, "coordinateSystem": "LPS", "coordinateUnits": "mm",
         "controlPoints": [{"id": str(n + 1), "label": f"{m.name}-{n + 1}", "position": [-x, -y, z],
                            "visibility": m.visible, "positionStatus": "defined"}
                           for n, (x, y, z) in enumerate(m.points)]}
        for m in markups.markups]}
    return json.dumps(document, indent=1) + "\n"


# --- reading ------------------------------------------------------------------------------------
def read_markups(path) -> Markups:
    """The markups of a file in the format of its name (module docstring)."""
    kind = file_format(path)
    text = _read_text(path)
    if kind == "csv":
        return _from_csv(path, text)
    data = _parse_json(path, text)
    return _from_slicer(path, data) if kind == "slicer" else _validated(path, "", lambda: Markups.model_validate(data))


def _read_text(path) -> str:
    try:
        with open(path, "rb") as file:
            data = file.read(MAX_FILE_BYTES + 1)
    except OSError as error:
        raise MarkupsFileError(path, "", f"cannot read the file: {error.strerror or error}") from None
    if len(data) > MAX_FILE_BYTES:
        raise MarkupsFileError(path, "", f"larger than a markups file can be ({MAX_FILE_BYTES} bytes)")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise MarkupsFileError(path, "", f"not UTF-8 text: {error.reason} at byte {error.start}") from None


def _parse_json(path, text: str):
    def reject_constant(name):
        raise ValueError(f"{name} is not a number a markups file may hold")
    try:
        data = json.loads(text, parse_constant=reject_constant)
    except json.JSONDecodeError as error:
        raise MarkupsFileError(path, "", f"not valid JSON: {error.msg} at line {error.lineno} "
                                         f"column {error.colno}") from None
    except RecursionError:
        raise MarkupsFileError(path, "", f"nested more than {MAX_NESTING} levels deep") from None
    except ValueError as error:
        raise MarkupsFileError(path, "", str(error)) from None
    if nesting_depth(data) > MAX_NESTING:
        raise MarkupsFileError(path, "", f"nested more than {MAX_NESTING} levels deep")
    return data


def _validated(path, where: str, build):
    """``build()``, its pydantic errors as a MarkupsFileError at ``where`` plus pydantic's location."""
    try:
        return build()
    except ValidationError as error:
        first = error.errors()[0]
        location = ".".join(str(p) for p in first.get("loc", ()))
        place = ".".join(part for part in (where, location) if part)
        raise MarkupsFileError(path, place, first["msg"]) from None


def _from_csv(path, text: str) -> Markups:
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or [cell.strip() for cell in rows[0]] != CSV_HEADER:
        raise MarkupsFileError(path, "line 1", f"the header must be {','.join(CSV_HEADER)}")
    groups: dict[str, dict] = {}
    for line, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        if len(row) != len(CSV_HEADER):
            raise MarkupsFileError(path, f"line {line}", f"expected {len(CSV_HEADER)} fields, got {len(row)}")
        name, kind, _, *coordinates = row
        group = groups.setdefault(name, {"name": name, "kind": kind, "points": []})
        if group["kind"] != kind:
            raise MarkupsFileError(path, f"line {line}", f"markup {shown(name)} is a {group['kind']} above "
                                                         f"and a {shown(kind)} here")
        group["points"].append([_number(path, line, axis, text) for axis, text in zip("xyz", coordinates)])
    markups = []
    for group in groups.values():
        markups.append(_validated(path, f"markup {shown(group['name'])}", lambda: Markup.model_validate(group)))
    return _validated(path, "", lambda: Markups(markups=tuple(markups)))


def _number(path, line: int, axis: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise MarkupsFileError(path, f"line {line}", f"{axis} is not a number: {shown(text)}") from None
    if not math.isfinite(value):
        raise MarkupsFileError(path, f"line {line}", f"{axis} must be a finite number, got {shown(text)}")
    return value


def _from_slicer(path, data) -> Markups:
    if not isinstance(data, dict) or not isinstance(data.get("markups"), list):
        raise MarkupsFileError(path, "markups", "a Slicer markups file holds a list 'markups'")
    stem = Path(path).name[:-len(".mrk.json")] or "markup"
    several = len(data["markups"]) > 1
    markups = []
    for index, entry in enumerate(data["markups"]):
        where = f"markups[{index}]"
        if not isinstance(entry, dict):
            raise MarkupsFileError(path, where, "each markup is an object")
        kind = SLICER_TYPES.get(entry.get("type"))
        if kind is None:
            raise MarkupsFileError(path, f"{where}.type", f"{shown(str(entry.get('type')))} is not a markup "
                                   f"vgraph holds (it reads {', '.join(SLICER_TYPES)})")
        system = entry.get("coordinateSystem", "LPS")  # the schema's default
        if system not in ("LPS", "RAS"):
            raise MarkupsFileError(path, f"{where}.coordinateSystem", f"must be LPS or RAS, got {shown(str(system))}")
        points = entry.get("controlPoints")
        if not isinstance(points, list):
            raise MarkupsFileError(path, f"{where}.controlPoints", "must be a list of control points")
        positions = [_position(path, f"{where}.controlPoints[{n}]", p, system) for n, p in enumerate(points)]
        name = entry.get("name") or (f"{stem}-{index + 1}" if several else stem)
        markup = {"name": name, "kind": kind, "points": positions}
        markups.append(_validated(path, where, lambda: Markup.model_validate(markup)))
    return _validated(path, "markups", lambda: Markups(markups=tuple(markups)))


def _position(path, where: str, point, system: str) -> list[float]:
    position = point.get("position") if isinstance(point, dict) else None
    if not (isinstance(position, list) and len(position) == 3
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in position)):
        raise MarkupsFileError(path, f"{where}.position", f"must be three finite numbers, got "
                                                          f"{shown(json.dumps(position))[:80]}")
    x, y, z = (float(v) for v in position)
    return [-x, -y, z] if system == "LPS" else [x, y, z]
