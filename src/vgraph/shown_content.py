"""What a renderer shows of its inputs, and where that lies in the world: the facts the blank-image
diagnosis (vgraph.blank_causes) reasons with.

A renderer says what it shows through ``Processor.shown_content()``: one Shown per input, made by the
helpers below: the voxels a transfer function gives opacity (``voxels_under``), the voxels that
reach an iso level (``voxels_reaching``), the voxels whose label the table shows
(``labelled_voxels``), every voxel (``every_voxel``: a slice mapped through a window) and the
tetrahedra a transfer function shows (``tetrahedra_under``). Each knows

- ``share()``: the fraction of its elements shown, classified as the shaders classify (the LUT
  read linearly between entries, clamped at its ends; non-finite voxels are not counted);
- ``presence(planes, crop_box)``: one walk over the shown elements (voxels in slabs of z, their
  centres in world units with the volume's direction; the four corners of each tetrahedron) that
  says how many show, the world box around them, how far each clip plane's kept side reaches into
  them, whether the crop box holds any, and the box around those every plane and the crop box
  keep. Kept in the one cache for derived data (vgraph.derived), by the data, the rule and the
  planes and crop box: a GUI drag with the camera looking away asks every frame.

A BrickedVolume larger than its memory budget is not read whole: ``share()`` is judged from its
summary level (as its histogram is) and its whole box stands in for where the shown voxels lie, so
a plane or camera is blamed only when it misses the whole box.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from vgraph import derived

SLAB_VOXELS = 2**19  # voxels per walk step: bounds the memory of the indices and points


@dataclass
class Presence:
    """Where the shown elements of an input lie (module docstring)."""

    shown: int = 0                                   # elements shown
    low: np.ndarray | None = None                    # world box around them (None: none shown)
    high: np.ndarray | None = None
    reach: list = field(default_factory=list)        # per plane: (min, max) of dot(p, n) - d
    in_crop: bool = False                            # the crop box (or no crop box) holds some
    kept: int = 0                                    # points every plane and the crop box keep
    kept_low: np.ndarray | None = None
    kept_high: np.ndarray | None = None

    def add(self, points: np.ndarray, count: int, planes, crop_box) -> None:
        """Count ``count`` shown elements whose world points are ``points`` (N, 3)."""
        if not len(points):
            return
        self.shown += count
        self.low, self.high = _grown(self.low, self.high, points)
        keep = np.ones(len(points), dtype=bool)
        for index, plane in enumerate(planes):
            height = points @ plane.unit_normal() - plane.offset()
            low, high = float(height.min()), float(height.max())
            if len(self.reach) <= index:
                self.reach.append((low, high))
            else:
                self.reach[index] = (min(self.reach[index][0], low), max(self.reach[index][1], high))
            keep &= height >= 0.0
        if crop_box is not None:
            inside = np.all((points >= np.asarray(crop_box[:3])) & (points <= np.asarray(crop_box[3:])), axis=1)
            self.in_crop |= bool(inside.any())
            keep &= inside
        else:
            self.in_crop = True
        kept = points[keep]
        if len(kept):
            self.kept += len(kept)
            self.kept_low, self.kept_high = _grown(self.kept_low, self.kept_high, kept)


def _grown(low, high, points):
    small, large = points.min(axis=0), points.max(axis=0)
    if low is None:
        return small, large
    return np.minimum(low, small), np.maximum(high, large)


class Shown:
    """What a renderer shows of one input (module docstring)."""

    noun = "voxels"

    def __init__(self, port: str, data, control: str, rule: str, key):
        self.port = port        # the inport it came through ("volume", "volume2", "mesh")
        self.data = data        # the Volume or TetMesh received
        self.control = control  # the property that decides what shows ("transfer_function", ...)
        self.rule = rule        # "transfer_function", "iso_level", "labels" or "window"
        self._key = (rule, key)

    def share(self) -> float:
        # A kind per rule: a ray caster's TF and a slice's window on one volume keep one each.
        return derived.value(self.data, f"shown share: {self.rule}", self._share, params=self._key)

    def presence(self, planes=(), crop_box=None) -> Presence:
        planes = tuple(planes)
        crop = None if crop_box is None else tuple(float(v) for v in crop_box)
        return derived.value(self.data, f"shown presence: {self.rule}", lambda: self._presence(planes, crop),
                             params=(self._key, planes, crop))

    def _share(self) -> float:
        raise NotImplementedError

    def _presence(self, planes, crop_box) -> Presence:
        raise NotImplementedError


class ShownVoxels(Shown):
    """Voxels that pass ``test``: of normalised intensities (``on_values`` False) or of the stored
    values (labels)."""

    def __init__(self, port, volume, control, rule, key, test, on_values: bool = False):
        super().__init__(port, volume, control, rule, key)
        self.test = test
        self.on_values = on_values

    def _passes(self, stored: np.ndarray) -> np.ndarray:
        shown = self.test(stored if self.on_values else self.data.normalized(stored))
        if stored.dtype.kind == "f":
            shown &= np.isfinite(stored)
        return shown

    def _share(self) -> float:
        volume = self.data
        if not self.on_values:
            return volume.share_of_voxels(self.test)
        passed = total = 0
        for slab in _z_slabs(volume.data):
            passed += int(np.count_nonzero(self._passes(slab)))
            total += slab.size if slab.dtype.kind != "f" else int(np.count_nonzero(np.isfinite(slab)))
        return passed / total if total else 0.0

    def _presence(self, planes, crop_box) -> Presence:
        presence = Presence()
        volume = self.data
        if not in_memory(volume):  # its box stands in for the shown voxels (module docstring)
            if self.share() > 0.0:
                corners = volume.voxel_to_world(unit_corners() * (np.asarray(volume.dims) - 1))
                presence.add(corners, 1, planes, crop_box)
            return presence
        start = 0
        for slab in _z_slabs(volume.data):
            k, j, i = np.nonzero(self._passes(slab))
            if k.size:
                points = volume.voxel_to_world(np.stack([i, j, k + start], axis=-1))
                presence.add(points, k.size, planes, crop_box)
            start += slab.shape[0]
        return presence


class ShownTetrahedra(Shown):
    """The tetrahedra of a mesh that ``mask`` (one boolean per tetrahedron) shows."""

    noun = "tetrahedra"

    def __init__(self, port, mesh, control, rule, key, mask: np.ndarray):
        super().__init__(port, mesh, control, rule, key)
        self.mask = np.asarray(mask, dtype=bool)

    def _share(self) -> float:
        return float(self.mask.mean()) if self.mask.size else 0.0

    def _presence(self, planes, crop_box) -> Presence:
        presence = Presence()
        shown = self.data.tets[self.mask]
        for start in range(0, len(shown), SLAB_VOXELS // 4):
            part = shown[start:start + SLAB_VOXELS // 4]
            points = self.data.points[part.reshape(-1)].astype(np.float64)
            presence.add(points, len(part), planes, crop_box)
        return presence


def in_memory(volume) -> bool:
    """Whether the volume's voxels can be read whole (not a BrickedVolume beyond its budget)."""
    return volume.bricks is None or getattr(volume, "fits_budget", True)


def _z_slabs(data: np.ndarray):
    step = max(1, SLAB_VOXELS // max(1, data.shape[1] * data.shape[2]))
    for start in range(0, data.shape[0], step):
        yield data[start:start + step]


def unit_corners() -> np.ndarray:
    """The 8 corners of the unit cube (8, 3), x fastest."""
    return np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=np.float64)


# --- what the renderers show ----------------------------------------------------------------------
def transfer_function_alpha(transfer_function, data) -> np.ndarray:
    """The opacity column of the TF's LUT for ``data`` (float64), as the shaders read it."""
    return transfer_function.for_volume(data).lut()[:, 3].astype(np.float64)


def voxels_under(port: str, volume, transfer_function, control: str = "transfer_function") -> ShownVoxels:
    """The voxels ``transfer_function`` gives any opacity."""
    alpha = transfer_function_alpha(transfer_function, volume)
    entries = np.linspace(0.0, 1.0, len(alpha))
    key = hashlib.blake2b(alpha.tobytes(), digest_size=16).hexdigest()
    return ShownVoxels(port, volume, control, "transfer_function", key,
                       lambda intensity: np.interp(intensity, entries, alpha) > 0.0)


def voxels_under_2d(port: str, volume, transfer_function_2d, control: str = "transfer_function_2d") -> ShownVoxels:
    """The voxels whose value a 2D TF (vgraph.transfer_function_2d) gives opacity at some gradient:
    its largest opacity per value, read as the 1D LUT is (an upper bound; the gradient decides)."""
    alpha = transfer_function_2d.lut()[..., 3].max(axis=0).astype(np.float64)
    entries = np.linspace(0.0, 1.0, len(alpha))
    key = hashlib.blake2b(alpha.tobytes(), digest_size=16).hexdigest()
    return ShownVoxels(port, volume, control, "transfer_function_2d", key,
                       lambda intensity: np.interp(intensity, entries, alpha) > 0.0)


def voxels_reaching(port: str, volume, level: float, control: str = "iso_level") -> ShownVoxels:
    """The voxels at or above the normalised iso ``level``: the inside of the surface."""
    level = float(level)
    return ShownVoxels(port, volume, control, "iso_level", level, lambda intensity: intensity >= level)


def voxels_by_compositing(port: str, volume, processor) -> ShownVoxels:
    """What a ray caster with ``compositing`` shows: iso, the voxels reaching its ``iso_level``;
    the other modes, the voxels its ``transfer_function`` shows."""
    if processor.compositing == "iso":
        return voxels_reaching(port, volume, processor.iso_level)
    return voxels_under(port, volume, processor.transfer_function)


def labelled_voxels(port: str, volume, label_table, control: str = "label_table") -> ShownVoxels:
    """The voxels whose label ``label_table`` shows (opacity above 0)."""
    held = held_labels(volume)
    shown = held[label_table.colors(held)[:, 3] > 0.0] if held.size else held
    return ShownVoxels(port, volume, control, "labels", tuple(shown.tolist()),
                       lambda values: np.isin(values, shown), on_values=True)


def every_voxel(port: str, volume, control: str = "window") -> ShownVoxels:
    """Every finite voxel (a slice mapped through a window shows each opaque)."""
    return ShownVoxels(port, volume, control, "window", None,
                       lambda intensity: np.ones(np.shape(intensity), dtype=bool))


def tetrahedra_under(port: str, mesh, transfer_function, mask, control: str = "transfer_function") -> ShownTetrahedra:
    """The tetrahedra ``mask`` says ``transfer_function`` shows (the renderer classifies them)."""
    mask = np.asarray(mask, dtype=bool)
    key = hashlib.blake2b(np.packbits(mask).tobytes(), digest_size=16).hexdigest()
    return ShownTetrahedra(port, mesh, control, "transfer_function", key, mask)


def held_labels(volume) -> np.ndarray:
    """The distinct finite whole values of a label volume (int64), once per volume."""
    return derived.value(volume, "held labels", lambda: _distinct_whole_values(volume.data))


def _distinct_whole_values(data) -> np.ndarray:
    values = np.unique(data)
    if values.dtype.kind == "f":
        values = values[np.isfinite(values)]
    return values.astype(np.int64)
