"""A rendering network around a volume file: what ``vgraph run FILE``, ``vgraph gui FILE`` and
``vgraph.load(FILE)`` give for a volume instead of a .json network.

The network is the one a user would wire first (docs/own-data.md)::

    VolumeSource 'source' -> EntryExitPoints 'eep' -> RayCaster 'rc' -> Canvas 'canvas'

with the cameras linked both ways, a camera that fits whatever volume arrives seen from the front
(automatic near/far; x right, y front, z up as in RAS-ordered files),
shaded direct volume rendering and the ``auto`` transfer function, which is placed by percentiles
(transfer_function.PRESETS) and so shows the densest part of any data set without knowing its
units. Every property can then be changed by id as in any network (``--set rc.transfer_function=
ct-bone``, ``--set source.window=robust``, ``--view front``).
"""

from __future__ import annotations

import os
from pathlib import Path

from vgraph.file_names import expanded
from vgraph.network import Network

IDS = {"source": "VolumeSource", "eep": "EntryExitPoints", "rc": "RayCaster", "canvas": "Canvas"}
WIRES = (("source.volume", "eep.volume"), ("source.volume", "rc.volume"), ("eep.entry", "rc.entry"),
         ("eep.exit", "rc.exit"), ("rc.image", "canvas.image"))


def is_volume_path(path: str | Path) -> bool:
    """Whether ``path`` names a volume (a file a VolumeSource reads, or a folder: a DICOM series)
    rather than a .json network."""
    from vgraph.io import SUPPORTED_EXTENSIONS
    path = Path(path)
    name = path.name.lower()
    if name.endswith(".json"):
        return False  # a network, even if it is not a file (the loader says what is wrong)
    return any(name.endswith(e) for e in SUPPORTED_EXTENSIONS) or os.path.isdir(path)  # False on a name too long


def volume_network(path: str | Path) -> Network:
    """The standard rendering network for the volume at ``path`` (read when evaluated)."""
    network = Network(base_dir=Path.cwd())
    network.description = f"Shaded volume rendering of {Path(path).name}"
    for row, (id, type_name) in enumerate(IDS.items()):
        network.add(type_name, id=id).position = (0.0, 120.0 * row)  # a column in the editor
    network.set("source.path", str(expanded(path).resolve()))
    network.set("rc.transfer_function", "auto")
    network.set("rc.shading", "blinn_phong")
    network.link("eep.camera", "rc.camera", bidirectional=True)
    network.set("eep.camera", network.get("eep.camera").viewed_from("front"))
    for source, target in WIRES:
        network.connect(source, target)
    return network
