"""Ink over an image through a coverage mask drawn on the CPU: what TextOverlay's caption and scale
bar and the Markups overlay share.

A processor draws into a Pillow "L" image (0: untouched, 255: fully covered; text with
``overlay_font``, Pillow's bundled default font, so nothing is read or downloaded at run time),
then ``CoverageOverlay.composite`` uploads it as an 8-bit one-channel texture (kept per size: a
sixteenth of an RGBA32F upload) and runs one pass (shaders/image/coverage_over.frag.glsl) that
puts the ink "over" the image (premultiplied, as ImageCompositor). Pixels the mask does not
touch are the input's, bit for bit.
"""

from __future__ import annotations

import numpy as np
from PIL import Image as PILImage
from PIL import ImageFont

from vgraph.gl.image_filters import premultiplied
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.shaders import programs
from vgraph.image import Image


def overlay_font(height_px: int) -> ImageFont.FreeTypeFont:
    """Pillow's bundled font at ``height_px`` pixels (as ColorBar's labels)."""
    return ImageFont.load_default(size=height_px)


class CoverageOverlay:
    """The texture and target one processor composites its coverage mask with."""

    def __init__(self):
        self._target = RenderTargets(1)
        self._coverage = None

    def composite(self, gl, image: Image, mask: PILImage.Image, color, owner: str) -> Image:
        """``color`` (straight RGBA) over ``image`` where ``mask`` covers it; ``owner`` names the
        processor in shader errors."""
        coverage = self._coverage_texture(gl, mask)
        program = programs.program(gl, FULLSCREEN_VERTEX_SHADER, "image/coverage_over.frag.glsl", processor=owner)
        (result,) = self._target.ensure(gl, image.size)
        fullscreen_pass(gl, program, result, textures={"image": image, "coverage": coverage},
                        uniforms={"ink": premultiplied(color)})
        return result

    def _coverage_texture(self, gl, mask: PILImage.Image):
        """The mask as an 8-bit normalised texture (a texel reads as value / 255), rows flipped to
        GL's bottom-up order; one texture kept per size."""
        texture = self._coverage
        if texture is None or texture.size != mask.size or texture.ctx is not gl:
            if texture is not None and texture.ctx is gl:
                texture.release()
            texture = self._coverage = gl.texture(mask.size, 1, dtype="f1", alignment=1)
        texture.write(np.ascontiguousarray(np.asarray(mask, dtype=np.uint8)[::-1]).tobytes())
        return texture
