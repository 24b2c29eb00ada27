"""Virtual stores by name: ``implicit:<function>?size=N&brick=B&<parameter>=<value>...`` opens an
ImplicitStore (implicit_store.py) as a BrickStore, wherever a path to an OME-Zarr store goes
(VolumeSource's path, a network file, ``--set src.path=...``; docs/guide/large-data.md, "Virtual
stores"). Examples: ``implicit:torus?size=8192``, ``implicit:sphere?size=16384&brick=128&radius=0.5``.

- ``function``: a name of vgraph.implicit.FUNCTIONS; its parameters as query fields (defaults for
  the others), checked by the function itself;
- ``size``: voxels per axis at level 0, an integer in SIZE_RANGE (default 1024);
- ``brick``: voxels per brick edge, a power of two in BRICK_RANGE (default 64), with at most
  store_metadata.MAX_BRICKS bricks at level 0.
Every problem raises ImplicitUrlError naming the URL and the field.
"""

from __future__ import annotations

import dataclasses
import math
from urllib.parse import parse_qsl, urlsplit

from vgraph.bricks.store_metadata import MAX_BRICKS
from vgraph.errors import PropertyError, VolumeFileError
from vgraph.implicit.functions import FUNCTIONS, make_function

SCHEME = "implicit:"
SIZE_RANGE = (16, 65536)   # 16: the smallest sample(); 65536^3 bytes is 256 TiB, past any use
BRICK_RANGE = (8, 256)     # pyramid bricks (foreign_stores.MIN_BRICK .. MAX_BRICK would allow 16..256)
DEFAULTS = {"size": 1024, "brick": 64}


class ImplicitUrlError(VolumeFileError):
    """An ``implicit:`` URL that names no virtual store: the field says which part is wrong."""


def is_implicit_url(text) -> bool:
    return isinstance(text, str) and text.startswith(SCHEME)


def parse_implicit_url(url: str):
    """(function, size, brick) of ``url``; ImplicitUrlError when any part is wrong."""
    parts = urlsplit(url)
    name = parts.path
    if parts.scheme != SCHEME[:-1] or parts.netloc or parts.fragment or not name:
        raise ImplicitUrlError(url, f"expected {SCHEME}<function>?size=N&brick=B, e.g. "
                                    f"{SCHEME}torus?size=8192", "function")
    if name not in FUNCTIONS:
        raise ImplicitUrlError(url, f"unknown function {name!r}; known: {', '.join(FUNCTIONS)}", "function")
    fields = _fields(url, parts.query)
    size = _integer(url, fields.pop("size", str(DEFAULTS["size"])), "size")
    brick = _integer(url, fields.pop("brick", str(DEFAULTS["brick"])), "brick")
    if not SIZE_RANGE[0] <= size <= SIZE_RANGE[1]:
        raise ImplicitUrlError(url, f"size must be {SIZE_RANGE[0]} to {SIZE_RANGE[1]} voxels per axis, "
                                    f"got {size}", "size")
    if not BRICK_RANGE[0] <= brick <= BRICK_RANGE[1] or brick & (brick - 1):
        raise ImplicitUrlError(url, f"brick must be a power of two from {BRICK_RANGE[0]} to "
                                    f"{BRICK_RANGE[1]}, got {brick}", "brick")
    bricks = math.ceil(size / brick) ** 3
    if bricks > MAX_BRICKS:
        raise ImplicitUrlError(url, f"size {size} in bricks of {brick} makes {bricks} bricks, more than "
                                    f"the {MAX_BRICKS} vgraph keeps ranges for: use a larger brick", "brick")
    known = [f.name for f in dataclasses.fields(FUNCTIONS[name])]
    for key in fields:
        if key not in known:
            raise ImplicitUrlError(url, f"unknown parameter {key!r}; {name} has: size, brick"
                                        f"{''.join(', ' + k for k in known)}", key)
    try:
        function = make_function(name, **{key: _number(url, value, key) for key, value in fields.items()})
    except PropertyError as error:
        where = error.where.partition("parameter '")[2].rstrip("'") or "function"
        raise ImplicitUrlError(url, error.reason, where) from None
    return function, size, brick


def open_implicit(url: str):
    """The virtual store ``url`` names, opened as vgraph opens every OME-Zarr image (an
    implicit_store.ImplicitBrickStore; zarr is imported here, when used: it takes 0.2 s)."""
    from vgraph.bricks.implicit_store import ImplicitBrickStore, ImplicitStore
    function, size, brick = parse_implicit_url(url)
    return ImplicitBrickStore(url, files=ImplicitStore(function, size, brick, name=url))


def _fields(url: str, query: str) -> dict[str, str]:
    try:
        pairs = parse_qsl(query, keep_blank_values=True, strict_parsing=bool(query))
    except ValueError:
        raise ImplicitUrlError(url, f"the query {query!r} is not name=value pairs joined by '&'",
                               "query") from None
    fields: dict[str, str] = {}
    for key, value in pairs:
        if key in fields:
            raise ImplicitUrlError(url, f"{key} is given twice", key)
        fields[key] = value
    return fields


def _integer(url: str, text: str, field: str) -> int:
    try:
        return int(text, 10)
    except ValueError:
        raise ImplicitUrlError(url, f"{field} must be a whole number, got {text!r}", field) from None


def _number(url: str, text: str, field: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ImplicitUrlError(url, f"{field} must be a number, got {text!r}", field) from None
