"""What the command line's values mean: path options, ``--size``, ``--set ID.PROPERTY=VALUE`` and
``--view`` applied to a network (``vgraph run`` and ``vgraph animate`` share them)."""

from __future__ import annotations

import argparse
import json
import os
import warnings
from pathlib import Path

from vgraph.bricks.implicit_url import is_implicit_url
from vgraph.errors import PropertyError, VGraphError, VGraphWarning
from vgraph.file_names import expanded, file_name_problem, shown
from vgraph.json_limits import MAX_NESTING, nesting_depth
from vgraph.network import split_address
from vgraph.transfer_function import PRESETS


def user_path(text: str) -> Path:
    """A path option's value, refused as a usage error (exit 2, naming the option) when the
    system could not take it as a file name (vgraph.file_names)."""
    problem = file_name_problem(text)
    if problem is not None:
        raise argparse.ArgumentTypeError(problem)
    return Path(text)


def parse_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 512x384, got '{text}'") from None
    return width, height


def parse_assignment(text: str) -> tuple[str, object]:
    """(address, value) of ``ID.PROPERTY=VALUE``: VALUE as JSON where it parses, nested no
    deeper than a network file may be (MAX_NESTING), else as the text itself."""
    address, equals, value = text.partition("=")
    address = address.strip()
    if not equals:
        raise VGraphError(f"--set {shown(text)}: expected ID.PROPERTY=VALUE")
    too_deep = PropertyError(address, f"the --set value {shown(value, 20)} is nested more than "
                                      f"{MAX_NESTING} levels deep")
    try:
        parsed = json.loads(value)
    except json.JSONDecodeError:
        return address, value  # a bare string such as a file name
    except RecursionError:  # deeper than Python's stack, so far deeper than the limit
        raise too_deep from None
    if nesting_depth(parsed) > MAX_NESTING:
        raise too_deep
    return address, parsed


def set_from_command_line(network, text: str) -> None:
    """Apply one ``--set``. A relative file path typed on the command line means the current
    folder, as for any command (in the .json file it means the file's folder): file path values,
    and a transfer function given as the name of an existing file, are made absolute first."""
    address, value = parse_assignment(text)
    processor_id, name = split_address(address, "property")
    prop = network[processor_id].properties.get(name)  # None: network.set names the known ones
    kind = prop.kind if prop is not None else None
    if kind == "file_path":
        raw = text.partition("=")[2]
        value = value if isinstance(value, str) else raw  # a file named 42 or null is still a name
        value = _from_cwd(value) if value and file_name_problem(value) is None else value
    elif kind == "transfer_function" and isinstance(value, str) and value not in PRESETS \
            and file_name_problem(value) is None:  # else the property names the problem
        candidate = expanded(value)
        if value and not candidate.is_absolute() and os.path.isfile(candidate):
            value = str(Path.cwd() / candidate)  # a preset name stays a name
    network.set(address, value)


def _from_cwd(value: str) -> str:
    if is_implicit_url(value):  # a virtual store's name, not a file (vgraph.bricks.implicit_url)
        return value
    path = expanded(value)
    return value if path.is_absolute() else str(Path.cwd() / path)


def set_view(network, name: str) -> None:
    """Turn every camera property of the network to ``camera.viewed_from(name)`` (the same loop
    docs/reference/general/cli.md shows for scripts, so a script gets the same image)."""
    turned = 0
    for processor in network.processors.values():
        for prop_name, prop in processor.properties.items():
            if prop.kind == "camera":
                address = f"{processor.id}.{prop_name}"
                network.set(address, network.get(address).viewed_from(name))
                turned += 1
    if not turned:
        warnings.warn(VGraphWarning(f"--view {name}: the network has no camera to turn"), stacklevel=2)
