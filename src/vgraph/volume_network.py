"""A rendering network around a data file: what ``vgraph run FILE``, ``vgraph gui FILE`` and
``vgraph.load(FILE)`` give for a volume or a picture instead of a .json network.

What the file holds chooses the network (vgraph.file_kind); each is the one a user would wire
first (docs/guide/own-data.md):

- a volume of intensities::

    VolumeSource 'source' -> EntryExitPoints 'eep' -> RayCaster 'rc' -> Canvas 'canvas'

  shaded direct volume rendering and the ``auto`` transfer function, which is placed by
  percentiles (transfer_function.PRESETS) and so shows the densest part of any data set without
  knowing its units;
- a volume of labels: the same with LabelRayCaster 'labels' in place of the RayCaster, shaded,
  every label but 0 (the background) in a colour of its own (file_labels.distinct_label_table);
- a single slice: VolumeSource 'source' -> SliceViewer 'slice' -> Canvas 'canvas', in the plane
  that holds the slice, intensities in the robust window (``source.window``), labels in their
  colours (nearest voxel, a step transfer function); the canvas has the slice's aspect;
- a picture (PNG, JPEG): ImageSource 'image' -> Canvas 'canvas' at the picture's size.

Ray casters get cameras linked both ways and fitting whatever volume arrives, seen from the front
(automatic near/far; x right, y front, z up as in RAS). Every property can then be changed by id
as in any network (``--set rc.transfer_function=ct-bone``, ``--set source.window=robust``,
``--view front``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from vgraph.file_kind import PICTURE_EXTENSIONS, FileKind, file_kind
from vgraph.file_labels import distinct_label_table
from vgraph.file_names import expanded
from vgraph.network import Network
from vgraph.transfer_function import TransferFunction

IDS = {"source": "VolumeSource", "eep": "EntryExitPoints", "rc": "RayCaster", "canvas": "Canvas"}
WIRES = (("source.volume", "eep.volume"), ("source.volume", "rc.volume"), ("eep.entry", "rc.entry"),
         ("eep.exit", "rc.exit"), ("rc.image", "canvas.image"))
LABEL_IDS = {"source": "VolumeSource", "eep": "EntryExitPoints", "labels": "LabelRayCaster",
             "canvas": "Canvas"}
LABEL_WIRES = (("source.volume", "eep.volume"), ("source.volume", "labels.labels"),
               ("eep.entry", "labels.entry"), ("eep.exit", "labels.exit"), ("labels.image", "canvas.image"))
SLICE_IDS = {"source": "VolumeSource", "slice": "SliceViewer", "canvas": "Canvas"}
SLICE_WIRES = (("source.volume", "slice.volume"), ("slice.image", "canvas.image"))
PICTURE_IDS = {"image": "ImageSource", "canvas": "Canvas"}
PICTURE_WIRES = (("image.image", "canvas.image"),)


def is_volume_path(path: str | Path) -> bool:
    """Whether ``path`` names a data file (a file a VolumeSource reads, a folder: a DICOM series,
    or a picture) rather than a .json network."""
    from vgraph.io import SUPPORTED_EXTENSIONS  # imported when used: its readers' libraries take 0.15 s
    path = Path(path)
    name = path.name.lower()
    if name.endswith(".json"):
        return False  # a network, even if it is not a file (the loader says what is wrong)
    return (any(name.endswith(e) for e in (*SUPPORTED_EXTENSIONS, *PICTURE_EXTENSIONS))
            or os.path.isdir(path))  # False on a name too long


def volume_network(path: str | Path, render_as: str | None = None, kind: FileKind | None = None) -> Network:
    """The standard network for the data file at ``path`` (read when evaluated): chosen by what
    the file holds (``kind``, default vgraph.file_kind.file_kind(path, render_as))."""
    kind = kind or file_kind(path, render_as)
    build = {"labels": _labels, "slice": _slice, "picture": _picture}.get(kind.kind, _volume)
    network = build(str(expanded(path).resolve()), kind)
    network.description = kind.sentence or f"Shaded volume rendering of {Path(path).name}"
    return network


def _column(ids: dict, wires) -> Network:
    network = Network(base_dir=Path.cwd())
    for row, (id, type_name) in enumerate(ids.items()):
        network.add(type_name, id=id).position = (0.0, 120.0 * row)  # a column in the editor
    for source, target in wires:
        network.connect(source, target)
    return network


def _framed(network: Network, caster: str) -> None:
    network.link("eep.camera", f"{caster}.camera", bidirectional=True)
    network.set("eep.camera", network.get("eep.camera").viewed_from("front"))


def _volume(path: str, kind: FileKind) -> Network:
    network = _column(IDS, WIRES)
    network.set("source.path", path)
    network.set("rc.transfer_function", "auto")
    network.set("rc.shading", "blinn_phong")
    _framed(network, "rc")
    return network


def _labels(path: str, kind: FileKind) -> Network:
    network = _column(LABEL_IDS, LABEL_WIRES)
    network.set("source.path", path)
    network.set("labels.label_table", distinct_label_table(kind.labels))
    network.set("labels.shading", "blinn_phong")
    _framed(network, "labels")
    return network


def _slice(path: str, kind: FileKind) -> Network:
    network = _column(SLICE_IDS, SLICE_WIRES)
    network.set("source.path", path)
    network.set("slice.orientation", kind.orientation)
    if kind.normal is not None:
        network.set("slice.normal", kind.normal)
    if kind.labels is None:
        network.set("source.window", "robust")
    else:  # each voxel its label's colour: no blending of label numbers
        network.set("slice.interpolation", "nearest")
        network.set("slice.mapping", "tf")
        network.set("slice.transfer_function", label_steps(kind.labels))
    network.set("canvas.size", kind.size)
    return network


def _picture(path: str, kind: FileKind) -> Network:
    network = _column(PICTURE_IDS, PICTURE_WIRES)
    network.set("image.path", path)
    if kind.size is not None:
        network.set("canvas.size", kind.size)
    return network


def label_steps(values) -> TransferFunction:
    """A transfer function in data values that gives each label of ``values`` its colour in
    distinct_label_table (0: black), opaque, constant within half a unit of the label. Exact for
    labels within 4096 of each other (the transfer function's table, transfer_function.LUT_SIZE)."""
    colors = distinct_label_table(values).colors(np.asarray(values))[:, :3]
    points = []
    for value, rgb in zip(values, colors):
        points += [(value - 0.5, *map(float, rgb), 1.0), (value + 0.5, *map(float, rgb), 1.0)]
    return TransferFunction(space="data", points=points)
