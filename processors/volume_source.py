"""VolumeSource: a volume from a file or a DICOM folder (formats: docs/volumes.md)."""

from vgraph import FilePathProperty, IntProperty, OptionProperty, Outport, Processor, VectorProperty, VGraphError
from vgraph.camera import MAX_COORDINATE
from vgraph.io import SUPPORTED_EXTENSIONS, read_volume
from vgraph.volume import Volume

RAW_TYPES = ["uint8", "int8", "uint16", "int16", "uint32", "int32", "float32", "float64"]


class VolumeSource(Processor):
    """Reads a volume file (QVis, raw, NRRD, NIfTI, MetaImage, DICOM folder, NumPy)."""

    category = "Volume"
    outports = [Outport("volume", Volume)]
    path = FilePathProperty("", filters=tuple(f"*{e}" for e in SUPPORTED_EXTENSIONS),
                            doc="the volume file, or a folder holding one DICOM series")
    spacing = VectorProperty(None, size=3, min=1.0 / MAX_COORDINATE, max=MAX_COORDINATE, optional=True,
                             doc="voxel spacing (x, y, z) in world units; empty: from the file")
    origin = VectorProperty(None, size=3, min=-MAX_COORDINATE, max=MAX_COORDINATE, optional=True,
                            doc="world position (x, y, z) of voxel (0, 0, 0); empty: from the file")
    value_range = VectorProperty(None, size=2, optional=True,
                                 doc="stored values mapped to intensities 0 and 1; empty: from the file or type")
    raw_dims = VectorProperty(None, size=3, min=1, integer=True, optional=True,
                              doc="for a headerless raw file: voxels (x, y, z)")
    raw_dtype = OptionProperty("uint8", choices=RAW_TYPES, doc="for a headerless raw file: voxel type")
    raw_endianness = OptionProperty("little", choices=["little", "big"], doc="for a headerless raw file")
    raw_offset = IntProperty(0, min=-1, doc="for a headerless raw file: header bytes to skip (-1: data at the end)")

    def process(self) -> Volume:
        if not self.path:
            raise VGraphError(f"{self.id}.path: no volume file chosen")
        volume = read_volume(self.resolve_path(self.path), raw=self._raw_description())
        return self._with_overrides(volume)

    def _raw_description(self) -> dict | None:
        if self.raw_dims is None:
            return None
        return {"dims": self.raw_dims, "dtype": self.raw_dtype, "endianness": self.raw_endianness,
                "offset": self.raw_offset}

    def _with_overrides(self, volume: Volume) -> Volume:
        if self.spacing is None and self.origin is None and self.value_range is None:
            return volume
        try:
            return volume.with_data(volume.data, spacing=self.spacing or volume.spacing,
                                    origin=self.origin or volume.origin,
                                    declared_range=self.value_range or volume.declared_range)
        except VGraphError as error:
            raise VGraphError(f"{self.id}: the overrides do not fit the volume: {error}") from None
