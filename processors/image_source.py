"""ImageSource: a PNG or JPEG file as an image."""

from __future__ import annotations

import io
import os
import struct
import warnings
import zlib

import numpy as np
import PIL.Image

from vgraph import FilePathProperty, Outport, Processor, VGraphError
from vgraph.image import Image
from vgraph.io import file_problem

# 8192 x 8192: an RGBA texture of 256 MiB. Larger pictures are refused from their header, before
# a pixel is decoded (PIL itself only warns up to twice its own limit of about 89 million).
MAX_PIXELS = 8192 * 8192
# PIL reads a chunk of the length a PNG chunk header claims with one file.read(n), which
# allocates n bytes (up to 2 GiB) before it finds the file shorter: PIL gets the file from memory,
# where a read past the end costs nothing. No picture within MAX_PIXELS needs a larger file.
MAX_FILE_BYTES = 1 * 2**30
# What PIL raises for damaged files besides OSError (its plug-ins use SyntaxError for bad chunks).
_DAMAGED = (OSError, SyntaxError, ValueError, EOFError, IndexError, struct.error, zlib.error,
            PIL.UnidentifiedImageError)


class ImageSource(Processor):
    """Reads a PNG or JPEG file into an image (8- and 16-bit channels)."""

    category = "Image"
    outports = [Outport("image", Image)]
    path = FilePathProperty("", filters=("*.png", "*.jpg", "*.jpeg"), doc="the image file")

    def awaiting(self) -> str | None:
        return None if self.path else "an image file"

    def process(self):
        return Image.from_numpy(self.gl, read_image_file(self.id, self.path, self.resolve_path(self.path)))


def read_image_file(processor_id: str, value: str, path) -> np.ndarray:
    if not value:
        raise VGraphError(f"{processor_id}.path: no image file chosen")
    problem = file_problem(path)  # before opening: a FIFO would block
    if problem is not None:
        problem = "not found" if problem == "does not exist" else problem
        raise VGraphError(f"{path}: file {problem} ({processor_id}.path)")
    try:
        content = _file_content(path, processor_id)
        with warnings.catch_warnings():  # PIL warns about sizes that _check_pixel_count refuses
            warnings.simplefilter("ignore", PIL.Image.DecompressionBombWarning)
            picture = PIL.Image.open(io.BytesIO(content))
        with picture:
            _check_pixel_count(picture.size, path, processor_id)
            picture.load()
            if picture.mode.startswith("I;16") or picture.mode == "I":
                return np.asarray(picture).astype(np.uint16)  # 16-bit grey keeps its precision
            return np.asarray(picture.convert("RGBA"))
    except PIL.Image.DecompressionBombError as error:  # raised by open() beyond 2x PIL's limit
        raise VGraphError(f"{path}: image too large ({processor_id}.path): {error}") from None
    except _DAMAGED as error:
        raise VGraphError(f"{path}: not a readable PNG or JPEG image ({processor_id}.path): "
                          f"{error}") from None


def _file_content(path, processor_id: str) -> bytes:
    size = os.path.getsize(path)
    if size > MAX_FILE_BYTES:
        raise VGraphError(f"{path}: image file too large ({processor_id}.path): {size} bytes, the "
                          f"limit is {MAX_FILE_BYTES}")
    with open(path, "rb") as fh:
        return fh.read()


def _check_pixel_count(size, path, processor_id: str) -> None:
    width, height = size
    if width * height > MAX_PIXELS:
        raise VGraphError(f"{path}: image too large ({processor_id}.path): {width} x {height} = "
                          f"{width * height} pixels, the limit is {MAX_PIXELS} (8192 x 8192)")
