"""How a data file is shown by ``vgraph run FILE``, ``vgraph gui FILE`` and ``vgraph.load(FILE)``:
what the file holds chooses the network (vgraph.volume_network builds it).

- ``picture``: a PNG or JPEG, shown as it is, at its own size (ImageSource -> Canvas).
- ``slice``: a volume one voxel thick along an axis (a single DICOM slice, a 1-slice NIfTI),
  shown as the image it is (SliceViewer) in the plane that holds it: the named orientation
  (axial, coronal, sagittal) whose normal lies along the world direction of the thin axis
  (Volume.direction), or a custom plane with that normal for an oblique slice. Intensities get
  the robust window (VolumeSource.window, percentiles 0.5..99.5); labels their distinct colours.
  Ray cast, such a volume is a box of zero thickness: black from the side, faint face-on.
- ``labels``: a volume of labels, declared by its file (Volume.holds_labels) or guessed from its
  values (vgraph.file_labels), rendered by the LabelRayCaster with a colour per label.
- ``volume``: anything else, the shaded ray casting with the ``auto`` transfer function.

``render_as`` ("labels" or "intensity"; the CLI's --labels / --intensity) overrides the guess
and the declaration. Choosing reads the volume once (OME-Zarr stores: their metadata only, so a
store is labels only when it says so); the VolumeSource reads it again when the network runs. A
file that cannot be read here gives the ``volume`` kind, so that its VolumeSource names the
problem when the network runs, as for any network.
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import PIL.Image

from vgraph.errors import VGraphError
from vgraph.file_labels import Labels, declared_labels, guessed_labels
from vgraph.slicing import ORIENTATIONS, plane_axes

RENDER_AS = ("labels", "intensity")
KINDS = ("volume", "labels", "slice", "picture")
PICTURE_EXTENSIONS = (".png", ".jpg", ".jpeg")
ALIGNED = 1.0 - 1e-6  # |cos| between a thin axis and a named normal for the named orientation
SLICE_PIXELS = 512    # a slice narrower than this is magnified by a whole factor up to it ...
MAX_PIXELS = 4096     # ... and one wider than this shrunk to it (the canvas' longer side)


@dataclass(frozen=True)
class FileKind:
    """The choice for one file: ``kind`` (KINDS), ``facts`` (what the file holds, "" when it
    could not be read), ``how`` (what is shown), ``forced`` (by render_as), ``ordinary`` (a volume
    of intensities that neither declares nor nearly looks like labels: nothing to explain), and
    what the network needs: the label values, the slice's orientation and normal, the canvas size."""
    kind: str
    facts: str
    how: str
    forced: bool = False
    ordinary: bool = False
    labels: tuple[int, ...] | None = None
    orientation: str = "axial"
    normal: tuple[float, float, float] | None = None
    size: tuple[int, int] | None = None

    @property
    def sentence(self) -> str:
        """One line saying what was chosen and why, e.g. "frog.vti holds 29 labels (integer
        values 0..28): rendered as labels by the LabelRayCaster"."""
        return f"{self.facts}: {self.how}" if self.facts else ""


def is_picture(path: str | Path) -> bool:
    return Path(path).name.lower().endswith(PICTURE_EXTENSIONS)


def file_kind(path: str | Path, render_as: str | None = None) -> FileKind:
    """What ``path`` holds and how it is shown (module docstring). VGraphError for a
    ``render_as`` the file cannot take (labels of fractional values, a picture)."""
    path = Path(path)
    if render_as is not None and render_as not in RENDER_AS:
        raise VGraphError(f"render_as must be one of {', '.join(RENDER_AS)}, got {render_as!r}")
    if is_picture(path):
        if render_as is not None:
            raise VGraphError(f"--{render_as}: {path.name} is a picture (PNG or JPEG), shown as it "
                              f"is; labels or intensities are chosen for volumes")
        return FileKind("picture", f"{path.name} is a picture", "shown as it is",
                        size=picture_size(path))
    volume = _read(path)
    if volume is None:
        return FileKind("volume", "", "the standard network; its VolumeSource names the problem")
    labels, facts, ordinary = _labels(volume, path.name, render_as)
    if 1 in volume.dims:
        return _slice(volume, path.name, labels, render_as is not None)
    if labels is not None:
        return FileKind("labels", facts, "rendered as labels by the LabelRayCaster",
                        forced=render_as is not None, labels=labels.values)
    return FileKind("volume", facts, "shaded volume rendering (RayCaster, auto transfer function)",
                    forced=render_as is not None, ordinary=ordinary)


def _read(path: Path):
    """The volume (an OME-Zarr store: its metadata), or None when it cannot be read."""
    from vgraph.io import read_volume  # imported when used: its readers' libraries take 0.15 s
    try:
        with warnings.catch_warnings():  # the VolumeSource warns again when the network runs
            warnings.simplefilter("ignore")
            return read_volume(path)
    except (VGraphError, MemoryError, OSError):
        return None


def _labels(volume, name: str, render_as: str | None) -> tuple[Labels | None, str, bool]:
    """(the volume's labels or None for intensities, the facts behind the choice, whether they
    are ordinary: intensities not declared otherwise and not near the rule for labels)."""
    labels, facts = _labels_and_facts(volume, name, render_as)
    ordinary = not labels.found and render_as is None and not volume.holds_labels and not labels.near_miss
    return (labels if labels.found else None), facts, ordinary


def _labels_and_facts(volume, name: str, render_as: str | None) -> tuple[Labels, str]:
    bricked = volume.bricks is not None and not volume.fits_budget  # else the LabelRayCaster reads it whole
    intensities = Labels(None, "")
    if render_as == "intensity":
        return intensities, f"{name}: intensities, as asked"
    if render_as == "labels":
        if bricked:
            raise VGraphError(f"--labels: {name} is a store larger than its memory budget, drawn "
                              f"brick by brick, and the LabelRayCaster draws labels from one texture")
        labels = declared_labels(volume)
        if not labels.found:
            raise VGraphError(f"--labels: {name} holds {labels.facts}; labels are whole numbers")
        return labels, f"{name}: {_counted(labels)}, as asked"
    if volume.holds_labels:
        if bricked:
            return intensities, (f"{name} declares labels, but a store larger than its memory "
                                 f"budget is drawn brick by brick and the LabelRayCaster needs one "
                                 f"texture, so its values are shown as intensities")
        labels = declared_labels(volume)
        if labels.found:
            return labels, f"{name} declares labels ({_counted(labels)})"
        return labels, f"{name} declares labels but holds {labels.facts}"
    if volume.bricks is not None:
        return intensities, f"{name} holds intensities (a store is labels only when it declares them)"
    labels = guessed_labels(volume)
    return labels, f"{name} holds {labels.facts}" if labels.found else f"{name} holds intensities ({labels.facts})"


def _counted(labels: Labels) -> str:
    values = labels.values
    return f"{len(values)} label values, {values[0]}..{values[-1]}"


# --- a single slice ---------------------------------------------------------------------------
def _slice(volume, name: str, labels: Labels | None, forced: bool) -> FileKind:
    orientation, normal = slice_orientation(volume)
    plane = "a custom plane" if orientation == "custom" else f"its {orientation} plane"
    what = f"{name} is a single slice ({' x '.join(map(str, volume.dims))} voxels)"
    if labels is not None:
        what += f" of {len(labels.values)} labels ({labels.values[0]}..{labels.values[-1]})"
        how = f"shown as an image in {plane}, a colour per label"
    else:
        how = f"shown as an image in {plane}, windowed to its 0.5..99.5 percentiles"
    return FileKind("slice", what, how, forced=forced, labels=None if labels is None else labels.values,
                    orientation=orientation, normal=normal, size=slice_size(volume, orientation, normal))


def thin_axis(volume) -> int:
    """The index axis (0 = x, 1 = y, 2 = z) along which the volume is one voxel thick (the last
    of several)."""
    return max(axis for axis, size in enumerate(volume.dims) if size == 1)


def slice_orientation(volume) -> tuple[str, tuple[float, float, float] | None]:
    """(orientation, custom normal or None): the named orientation whose normal is closest to
    the world direction of the volume's thin axis, exact up to ALIGNED; else ``custom`` with
    that direction as the normal, turned to the side of the closest named one's."""
    axis = np.asarray(volume.direction, dtype=np.float64)[:, thin_axis(volume)]
    best = max(ORIENTATIONS, key=lambda name: abs(float(plane_axes(name)[0] @ axis)))
    cosine = float(plane_axes(best)[0] @ axis)
    if abs(cosine) >= ALIGNED:
        return best, None
    return "custom", tuple(float(v) for v in (axis if cosine > 0 else -axis))


def slice_size(volume, orientation: str, normal) -> tuple[int, int]:
    """The canvas size (width, height) of a slice: the aspect of the volume's box projected onto
    the plane, the longer side the number of voxels along it, magnified by a whole factor up to
    SLICE_PIXELS and at most MAX_PIXELS."""
    _, right, up = plane_axes(orientation, normal)
    edges = np.asarray(volume.direction, dtype=np.float64) * (np.asarray(volume.dims) * np.asarray(volume.spacing))
    width, height = float(np.abs(right @ edges).sum()), float(np.abs(up @ edges).sum())
    voxels = max(size for axis, size in enumerate(volume.dims) if axis != thin_axis(volume))
    longer = voxels * max(1, SLICE_PIXELS // voxels)
    return _fitted(width, height, min(longer, MAX_PIXELS))


def picture_size(path: Path) -> tuple[int, int] | None:
    """A picture's (width, height) from its header (at most MAX_PIXELS on the longer side), or
    None when it cannot be read here (the ImageSource names the problem when it runs)."""
    try:
        if not os.path.isfile(path):
            return None
        with PIL.Image.open(path) as picture:
            width, height = picture.size
    except (OSError, SyntaxError, ValueError, PIL.Image.DecompressionBombError):
        return None
    return _fitted(width, height, min(max(width, height), MAX_PIXELS))


def _fitted(width: float, height: float, longer: int) -> tuple[int, int]:
    """(w, h) with the aspect width : height and the longer side ``longer`` pixels."""
    if width >= height:
        return longer, max(1, min(longer, math.floor(longer * height / width + 0.5)))
    return max(1, min(longer, math.floor(longer * width / height + 0.5))), longer
