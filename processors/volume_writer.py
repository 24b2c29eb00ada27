"""VolumeWriter: a sink that saves a volume (.npy, .npz, .nrrd, .nii, .nii.gz), atomically."""

from vgraph import FilePathProperty, Inport, Processor, VGraphError
from vgraph.atomic import check_output_path
from vgraph.io import WRITABLE_EXTENSIONS, write_volume
from vgraph.volume import Volume


class VolumeWriter(Processor):
    """Writes its input volume to a file; the format follows the extension."""

    category = "Output"
    inports = [Inport("volume", Volume)]
    path = FilePathProperty("volume.nrrd", filters=tuple(f"*{e}" for e in WRITABLE_EXTENSIONS), writes=True,
                            doc="where the volume is written (.npy, .npz, .nrrd, .nii, .nii.gz)")

    def process(self, volume: Volume) -> None:
        if not self.path:
            raise VGraphError(f"{self.id}.path: no output file chosen")
        path = check_output_path(self.resolve_path(self.path), create_folder=True)  # batch jobs write into fresh folders
        write_volume(volume, path)
