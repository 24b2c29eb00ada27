"""ImageSource: a PNG or JPEG file as an image."""

from __future__ import annotations

import numpy as np
import PIL.Image

from vgraph import FilePathProperty, Outport, Processor, VGraphError
from vgraph.image import Image


class ImageSource(Processor):
    """Reads a PNG or JPEG file into an image (8- and 16-bit channels)."""

    category = "Image"
    outports = [Outport("image", Image)]
    path = FilePathProperty("", filters=("*.png", "*.jpg", "*.jpeg"), doc="the image file")

    def process(self):
        return Image.from_numpy(self.gl, read_image_file(self.id, self.path, self.resolve_path(self.path)))


def read_image_file(processor_id: str, value: str, path) -> np.ndarray:
    if not value:
        raise VGraphError(f"{processor_id}.path: no image file chosen")
    try:
        with PIL.Image.open(path) as picture:
            picture.load()
            if picture.mode.startswith("I;16") or picture.mode == "I":
                return np.asarray(picture).astype(np.uint16)  # 16-bit grey keeps its precision
            return np.asarray(picture.convert("RGBA"))
    except FileNotFoundError:
        raise VGraphError(f"{path}: file not found ({processor_id}.path)") from None
    except (OSError, PIL.UnidentifiedImageError, ValueError) as error:
        raise VGraphError(f"{path}: not a readable PNG or JPEG image ({processor_id}.path): {error}") from None
