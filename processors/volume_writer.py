"""VolumeWriter: a sink that saves a volume (.npy, .npz, .nrrd, .nii, .nii.gz, .mha, .vti),
atomically; every format but .npy keeps the grid (spacing, origin, direction: vgraph.io.writers)."""

from vgraph import FilePathProperty, Inport, Processor
from vgraph.atomic import check_output_path
from vgraph.io import WRITABLE_EXTENSIONS, write_volume
from vgraph.volume import Volume
from vgraph.write_paths import writable_path, write_confinement


class VolumeWriter(Processor):
    """Writes its input volume to a file; the format follows the extension."""

    category = "Output"
    inports = [Inport("volume", Volume)]
    path = FilePathProperty("volume.nrrd", filters=tuple(f"*{e}" for e in WRITABLE_EXTENSIONS), writes=True,
                            doc="where the volume is written (.npy, .npz, .nrrd, .nii, .nii.gz, .mha, "
                                ".vti; all but .npy keep the spacing, origin and direction)")

    def process(self, volume: Volume) -> None:
        path, inside = writable_path(self, "path"), write_confinement(self, "path")  # as vgraph validate checked
        check_output_path(path, create_folder=True, inside=inside)  # batch jobs write into fresh folders
        write_volume(volume, path, inside=inside)
