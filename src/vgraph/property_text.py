"""A property declaration in words, for people: its kind with the range or choices, and its
default. ``vgraph list`` prints one line per property from these; the processor reference pages
(vgraph.reference_docs) put the same words in table columns, so the two never disagree.
"""

from __future__ import annotations

from vgraph.properties import Property


def property_text(prop: Property) -> str:
    """One line of ``vgraph list``: name, kind with its choices or range, default, e.g.
    ``compositing (option: dvr|mip) = 'dvr'``, ``sampling_rate (float 0.05..16) = 1.0``."""
    return f"{prop.name} ({kind_text(prop)}) = {default_text(prop)}"


def kind_text(prop: Property) -> str:
    """The kind with what limits a value: ``option: dvr|mip``, ``float 0.05..16``, ``3 ints >= 1``."""
    kind = prop.kind
    if kind == "option":
        return f"option: {'|'.join(prop.choices)}"
    if kind == "int" and prop.choices:
        return f"int: {'|'.join(str(c) for c in prop.choices)}"
    if kind in ("float", "int"):
        return f"{kind} {range_text(prop.min, prop.max)}".rstrip()
    if kind == "vector":
        number = "int" if prop.integer else "float"
        text = f"{prop.size} {number}s {range_text(prop.min, prop.max)}".rstrip()
        return text + (", or None" if prop.optional else "")
    if kind == "file_path":
        return f"file_path{', written' if prop.writes else ''}: {' '.join(prop.filters)}"
    if kind == "color":
        return "color: RGBA 0..1"
    return kind


def range_text(low, high) -> str:
    """``0.05..16``, ``>= 1``, ``<= 8``, or empty for a value without bounds."""
    number = lambda v: f"{v:g}" if isinstance(v, float) else str(v)  # noqa: E731
    if low is not None and high is not None:
        return f"{number(low)}..{number(high)}"
    return f">= {number(low)}" if low is not None else f"<= {number(high)}" if high is not None else ""


def default_text(prop: Property) -> str:
    """The default as its JSON value, or in words where that is long (a camera, a TF's points)."""
    value = prop.to_json(prop.default)
    if prop.kind == "camera":
        planes = ", automatic near/far" if value.get("near") is None and value.get("far") is None else ""
        where = "frames the data" if value.get("fit_to_data") else f"at {value.get('position')}"
        return f"{value.get('projection')} camera, fov {value.get('fov'):g}, {where}{planes}"
    if prop.kind == "transfer_function" and isinstance(value, dict) and "points" in value:
        space = f", {value['space']}" if value.get("space") else ""
        return f"{len(value['points'])} points{space} (--json lists them)"
    text = repr(value)
    return text if len(text) <= 80 else text[:76] + " ..."
