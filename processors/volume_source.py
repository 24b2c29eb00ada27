"""VolumeSource: a volume from a file or a DICOM folder (formats and the value-range rule:
docs/guide/volumes.md).

The value range a volume gets, first match wins: the ``value_range`` property; the ``robust``
window (percentiles of the data, for scans whose few outlier voxels would squeeze the bulk into
a sliver of [0, 1]); a range the file declares; the data's own min..max.

An OME-Zarr store (a folder ending in .zarr, or its zarr.json) opens as a BrickedVolume: its grid
and range come from the store's metadata and no voxel is read until a consumer needs them; the
whole array loads only within ``memory_budget`` (docs/guide/large-data.md). So does a virtual
store named by an ``implicit:`` URL (vgraph.bricks.implicit_url: an implicit function whose chunks
are computed when read), which is not a file and is never resolved against the network's folder.
"""

import warnings
from pathlib import Path

from vgraph import (FilePathProperty, FloatProperty, IntProperty, OptionProperty, Outport, Processor,
                    PropertyError, VectorProperty, VGraphError, VGraphWarning)
from vgraph.bricks.implicit_url import is_implicit_url, open_implicit
from vgraph.bricks.volume import DEFAULT_MEMORY_BUDGET_MB, BrickedVolume
from vgraph.camera import MAX_COORDINATE
from vgraph.errors import VolumeFileError
from vgraph.io import SUPPORTED_EXTENSIONS, TimeStepError, describes_itself, is_zarr_group, read_volume
from vgraph.volume import Volume, VolumeGeometryError

RAW_TYPES = ["uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64"]


RAW_FIELDS = {"raw_dims", "raw_dtype", "raw_endianness", "raw_offset"}  # headerless files only


class VolumeSource(Processor):
    """Reads a volume file (QVis, raw, NRRD, NIfTI, MetaImage, DICOM folder, NumPy)."""

    category = "Volume"
    outports = [Outport("volume", Volume)]
    path = FilePathProperty("", filters=tuple(f"*{e}" for e in SUPPORTED_EXTENSIONS) + ("zarr.json",),
                            doc="the volume file, a folder holding one DICOM series, an "
                                "OME-Zarr store (.zarr folder), or a virtual store of an implicit "
                                "function: implicit:torus?size=8192&brick=64 (docs/guide/large-data.md)")
    time_step = IntProperty(0, min=0, doc="of a file with a time axis (4D NIfTI, ...): the time "
                                          "point to read, 0 = the first")
    channel = IntProperty(0, min=0, doc="of an OME-Zarr store with a channel axis (c): the channel "
                                        "to read, 0 = the first")
    spacing = VectorProperty(None, size=3, min=1.0 / MAX_COORDINATE, max=MAX_COORDINATE, optional=True,
                             doc="voxel spacing (x, y, z) in world units; empty: from the file")
    origin = VectorProperty(None, size=3, min=-MAX_COORDINATE, max=MAX_COORDINATE, optional=True,
                            doc="world position (x, y, z) of voxel (0, 0, 0); empty: from the file")
    value_range = VectorProperty(None, size=2, optional=True,
                                 doc="stored values mapped to intensities 0 and 1; empty: by the window")
    window = OptionProperty("full", choices=["full", "robust"],
                            doc="the value range when none is given: full = the range the file "
                                "declares, else the data's min..max; robust = the window_percentiles "
                                "of the data (outliers clipped)")
    window_percentiles = VectorProperty((0.5, 99.5), size=2, min=0, max=100,
                                        doc="low and high percentile of the robust window")
    raw_dims = VectorProperty(None, size=3, min=1, integer=True, optional=True,
                              doc="for a headerless raw file: voxels (x, y, z)")
    raw_dtype = OptionProperty("uint8", choices=RAW_TYPES, doc="for a headerless raw file: voxel type")
    raw_endianness = OptionProperty("little", choices=["little", "big"], doc="for a headerless raw file")
    raw_offset = IntProperty(0, min=-1, doc="for a headerless raw file: header bytes to skip (-1: data at the end)")
    memory_budget = FloatProperty(DEFAULT_MEMORY_BUDGET_MB, min=1.0,
                                  doc="for an OME-Zarr store: MiB its whole full-resolution array "
                                      "may take when a processor needs it (larger: refused)")

    def check(self) -> None:
        low, high = self.window_percentiles
        if not low < high:
            raise PropertyError(f"{self.id}.window_percentiles",
                                f"the low percentile must be below the high one, got ({low:g}, {high:g})")

    def values_in_use(self) -> dict:
        volume = self.outputs.get("volume")
        if volume is None:
            return {}
        used = {"spacing": volume.spacing, "origin": volume.origin, "value_range": volume.value_range}
        return {name: tuple(float(v) for v in value) for name, value in used.items()
                if self.property_values[name] is None}

    def inapplicable(self) -> set[str]:
        if not self.path:
            return set()
        if is_implicit_url(self.path):
            return set(RAW_FIELDS)
        path = Path(self.resolve_path(self.path))
        hidden = set() if zarr_store(path) is not None else {"memory_budget"}
        return hidden | (RAW_FIELDS if describes_itself(path) else set())

    def awaiting(self) -> str | None:
        return None if self.path else "a volume file"

    def process(self) -> Volume:
        self.check()
        if not self.path:
            raise VGraphError(f"{self.id}.path: no volume file chosen")
        try:
            volume = self._read(self.path if is_implicit_url(self.path) else self.resolve_path(self.path))
        except TimeStepError as error:
            count = error.time_steps
            held = "1 time point (0)" if count == 1 else f"{count} time points (0 .. {count - 1})"
            raise PropertyError(f"{self.id}.time_step", f"time step {error.time_step} is out of "
                                f"range: {error.file} holds {held}") from None
        except VolumeFileError as error:
            if error.field == "channel":  # the property to change, not the file's field
                raise PropertyError(f"{self.id}.channel", f"{error.file}: {error.reason}") from None
            raise
        self._warn_if_flat(volume)
        return self._with_overrides(volume)

    def _read(self, path) -> Volume:
        if is_implicit_url(path):
            return BrickedVolume(open_implicit(path), memory_budget_mb=self.memory_budget)
        store = zarr_store(Path(path))
        if store is not None:
            return BrickedVolume.open(store, time_step=self.time_step, channel=self.channel,
                                      memory_budget_mb=self.memory_budget)
        return read_volume(path, raw=self._raw_description(Path(path)), time_step=self.time_step)

    def _raw_description(self, path: Path) -> dict | None:
        if self.raw_dims is None:
            return None
        if describes_itself(path):  # a network used as a template on another file
            warnings.warn(VGraphWarning(
                f"{self.id}.raw_dims is ignored: {path.name} has a header of its own (the raw "
                f"settings describe headerless files; set source.raw_dims=null to silence this)"),
                stacklevel=2)
            return None
        return {"dims": self.raw_dims, "dtype": self.raw_dtype, "endianness": self.raw_endianness,
                "offset": self.raw_offset}

    def _with_overrides(self, volume: Volume) -> Volume:
        value_range = self.value_range or self._robust_window(volume)
        if self.spacing is None and self.origin is None and value_range is None:
            return volume
        try:
            if isinstance(volume, BrickedVolume):  # regridded without reading its voxels
                return volume.with_overrides(self.spacing, self.origin, value_range)
            return volume.with_data(volume.data, spacing=self.spacing or volume.spacing,
                                    origin=self.origin or volume.origin,
                                    declared_range=value_range or volume.declared_range)
        except VolumeGeometryError as error:  # the box the overridden spacing or origin gives
            field = "spacing" if self.spacing is not None else "origin"
            raise PropertyError(f"{self.id}.{field}", f"{volume.source or 'the volume'}: "
                                                     f"{error.reason}") from None
        except VGraphError as error:
            raise VGraphError(f"{self.id}: the overrides do not fit the volume: {error}") from None

    def _robust_window(self, volume: Volume) -> tuple[float, float] | None:
        if self.window != "robust":
            return None
        low, high = (float(v) for v in volume.percentiles(self.window_percentiles))
        if low < high:
            return (low, high)
        # More voxels than the band between the percentiles share one value (a mostly empty
        # scan): a window of width zero maps nothing, so the full range stays.
        warnings.warn(VGraphWarning(
            f"{self.id}.window_percentiles: the {self.window_percentiles[0]:g}th and "
            f"{self.window_percentiles[1]:g}th percentiles of {volume.source} are both {low:g}; "
            f"using the full value range {volume.value_range} instead"), stacklevel=2)
        return None

    def _warn_if_flat(self, volume: Volume) -> None:
        """A volume one voxel thick spans a box of zero thickness along that axis: face-on it is
        a flat plane, from the side nothing at all, which looks like a broken renderer. Said only
        where it is drawn so: a SliceViewer shows such a volume as the image it is."""
        flat = [axis for axis, size in zip("xyz", volume.dims) if size == 1]
        if flat and not self._feeds_only_slices():
            warnings.warn(VGraphWarning(
                f"{self.id}: {volume.source} is one voxel thick along {' and '.join(flat)} "
                f"({' x '.join(map(str, volume.dims))} voxels): its box has zero thickness there, "
                f"so it renders as a flat plane seen face-on and as nothing from the side"),
                stacklevel=2)

    def _feeds_only_slices(self) -> bool:
        network = self.network
        consumers = [network[c.target].type_name for c in network.connections_of(self.id)
                     if c.source == self.id] if network is not None else []
        return bool(consumers) and all(name == "SliceViewer" for name in consumers)


def zarr_store(path: Path) -> Path | None:
    """The store folder when ``path`` is an OME-Zarr store or its zarr.json (what a file
    dialog can pick), else None."""
    if path.name.lower() in ("zarr.json", ".zgroup", ".zattrs") and \
            (path.parent.suffix.lower() == ".zarr" or is_zarr_group(path.parent)):
        path = path.parent
    is_store = path.suffix.lower() == ".zarr" or is_zarr_group(path)  # also an image inside a store
    return path if is_store and path.is_dir() else None
