"""ImageWriter: a sink that saves its image as an 8-bit PNG."""

from vgraph import FilePathProperty, Inport, Processor
from vgraph.atomic import check_output_path
from vgraph.image import Image
from vgraph.imagefile import write_png
from vgraph.write_paths import writable_path, write_confinement


class ImageWriter(Processor):
    """Writes its input image to a PNG file (RGBA, 8 bit; written atomically)."""

    category = "Output"
    inports = [Inport("image", Image)]
    path = FilePathProperty("out.png", filters=("*.png",), writes=True, doc="where the PNG is written")

    def process(self, image: Image) -> None:
        path, inside = writable_path(self, "path"), write_confinement(self, "path")  # as vgraph validate checked
        check_output_path(path, create_folder=True, inside=inside)  # batch jobs write into fresh folders
        write_png(path, image.to_numpy(), inside=inside)
