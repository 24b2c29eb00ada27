"""ImageWriter: a sink that saves its image as an 8-bit PNG."""

from pathlib import Path

from vgraph import FilePathProperty, Inport, Processor, VGraphError
from vgraph.atomic import check_output_path
from vgraph.image import Image
from vgraph.imagefile import write_png


class ImageWriter(Processor):
    """Writes its input image to a PNG file (RGBA, 8 bit; written atomically)."""

    category = "Output"
    inports = [Inport("image", Image)]
    path = FilePathProperty("out.png", filters=("*.png",), writes=True, doc="where the PNG is written")

    def process(self, image: Image) -> None:
        if not self.path:
            raise VGraphError(f"{self.id}.path: no output file chosen")
        path = self.resolve_path(self.path)
        if Path(path).suffix.lower() != ".png":
            raise VGraphError(f"{self.id}.path: '{self.path}' must end in .png")
        check_output_path(path, create_folder=True)  # batch jobs write into fresh folders
        write_png(path, image.to_numpy())
