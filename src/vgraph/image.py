"""The Image port data type: an RGBA float image that lives on the GPU.

Conventions:
- An Image is an RGBA32F 2D texture on one moderngl context; ``size`` is (width, height) in pixels.
  It stays on the GPU between processors; ``to_numpy()`` reads it back only when asked.
- numpy side: arrays are (height, width[, channels]) with row 0 at the TOP of the image (as in image
  files and matplotlib). GL stores row 0 at the BOTTOM, so uploads and read-backs flip the rows; in
  shaders v = 0 is the bottom row.
- Uploads: uint8 is scaled by 1/255, uint16 by 1/65535, bool to 0/1, other types are kept as values.
  One channel (H x W or H x W x 1) becomes grey (g, g, g, 1); three channels get alpha 1.
- Sampling is linear and clamped to the edge.
- ``covered`` may bound where a producer drew: (x, y, width, height) in GL window coordinates (y
  up from the bottom row), outside of which every pixel is transparent (alpha 0). None: anywhere.
  EntryExitPoints sets it to its box's footprint, so a ray caster draws only there.
"""

from __future__ import annotations

import io

import numpy as np
import PIL.Image

from vgraph.errors import VGraphError
from vgraph.gl_context import bind_default_framebuffer
from vgraph.imagefile import to_uint8

_NORMALISED_MAX = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}


class Image:
    """An RGBA32F texture with a lazily created framebuffer for rendering into it."""

    def __init__(self, ctx, texture):
        self.ctx = ctx
        self.texture = texture
        self._framebuffer = None
        self.covered: tuple[int, int, int, int] | None = None  # (module docstring)

    # ------------------------------------------------------------------ construction
    @classmethod
    def empty(cls, ctx, size: tuple[int, int]) -> "Image":
        """A (width, height) image cleared to transparent black."""
        image = cls(ctx, _new_texture(ctx, _checked_size(ctx, size)))
        image.framebuffer.clear(0.0, 0.0, 0.0, 0.0)
        return image

    @classmethod
    def from_numpy(cls, ctx, array) -> "Image":
        """Upload an (H, W), (H, W, 1), (H, W, 3) or (H, W, 4) array; row 0 is the top."""
        rgba = _to_rgba_float32(np.asarray(array))
        height, width = rgba.shape[:2]
        texture = _new_texture(ctx, _checked_size(ctx, (width, height)))
        texture.write(np.ascontiguousarray(rgba[::-1]).tobytes())
        return cls(ctx, texture)

    # ------------------------------------------------------------------ access
    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return tuple(self._live_texture().size)

    @property
    def framebuffer(self):
        """A framebuffer with this image as its only colour attachment (created on first use)."""
        if self._framebuffer is None:
            self._framebuffer = self.ctx.framebuffer(color_attachments=[self._live_texture()])
        return self._framebuffer

    def to_numpy(self) -> np.ndarray:
        """The pixels as float32 (height, width, 4), row 0 at the top."""
        width, height = self.size
        flat = np.frombuffer(self._live_texture().read(), dtype=np.float32)
        return flat.reshape(height, width, 4)[::-1].copy()

    def _repr_png_(self) -> bytes:
        """PNG bytes of the pixels, 8-bit RGBA as ``vgraph run -o`` writes them: Jupyter and IPython
        show an Image inline through this."""
        buffer = io.BytesIO()
        PIL.Image.fromarray(to_uint8(self.to_numpy())).save(buffer, format="PNG")
        return buffer.getvalue()

    def release(self) -> None:
        """Free the GPU memory now (instead of when moderngl's garbage collection gets to it)."""
        if self._framebuffer is not None:
            bind_default_framebuffer(self.ctx)
            self._framebuffer.release()
            self._framebuffer = None
        if self.texture is not None:
            self.texture.release()
            self.texture = None

    def __repr__(self) -> str:
        state = f"{self.size[0]}x{self.size[1]}" if self.texture is not None else "released"
        return f"Image({state})"

    def _live_texture(self):
        if self.texture is None:
            raise VGraphError("this Image was released; its pixels are gone")
        return self.texture


def _new_texture(ctx, size: tuple[int, int]):
    texture = ctx.texture(size, 4, dtype="f4")
    texture.repeat_x = texture.repeat_y = False
    return texture


def _checked_size(ctx, size) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in size)
    except (TypeError, ValueError):
        raise VGraphError(f"image size must be (width, height), got {size!r}") from None
    limit = ctx.info["GL_MAX_TEXTURE_SIZE"]
    if not (1 <= width <= limit and 1 <= height <= limit):
        raise VGraphError(f"image size {width}x{height} outside 1..{limit} (GL_MAX_TEXTURE_SIZE)")
    return width, height


def _to_rgba_float32(array: np.ndarray) -> np.ndarray:
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or array.shape[2] not in (1, 3, 4):
        raise VGraphError(f"image array must be H x W or H x W x 1/3/4, got shape {array.shape}")
    if array.dtype.kind not in "biuf":
        raise VGraphError(f"image array must be numeric, got dtype {array.dtype}")
    # Divide (not multiply by 1/255) so that the full-scale value maps to exactly 1.0.
    values = array.astype(np.float32) / np.float32(_NORMALISED_MAX.get(array.dtype, 1.0))
    height, width, channels = values.shape
    rgba = np.ones((height, width, 4), dtype=np.float32)
    if channels == 1:
        rgba[:, :, :3] = values
    else:
        rgba[:, :, :channels] = values
    return rgba
