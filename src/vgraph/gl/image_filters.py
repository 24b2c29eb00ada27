"""Shared parts of the image filter processors (ImageBlur, EdgeDetect, DepthDarkening): the
separable Gaussian as two fullscreen passes; and a colour property's value as the premultiplied
RGBA that images hold (ImageThreshold, Background, TextOverlay).

Conventions: the Gaussian is scipy.ndimage.gaussian_filter's with ``truncate`` 4 and border mode
'nearest' (the edge pixel repeats, as the Image's clamped sampling): weights exp(-x^2 / 2 sigma^2)
for |x| <= int(4 sigma + 0.5), normalised per axis. sigma 0 copies the image. Every channel is
filtered alike, so premultiplied colour stays premultiplied (shaders/image/gaussian_pass.glsl).
"""

from __future__ import annotations

from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.shaders import programs
from vgraph.image import Image

TRUNCATE = 4.0  # scipy.ndimage.gaussian_filter's default, in standard deviations
GAUSSIAN_SHADER = "image/gaussian_blur.frag.glsl"


def gaussian_radius(sigma: float) -> int:
    """The kernel's half width in pixels, as scipy computes it."""
    return int(TRUNCATE * float(sigma) + 0.5)


def gaussian_blur(ctx, image: Image, across: Image, result: Image, sigma: float, processor: str) -> None:
    """Blur ``image`` into ``result`` through ``across`` (the rows done, an image of the same size)."""
    program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, GAUSSIAN_SHADER, processor=processor)
    # sigma 0: one weight of 1 (the shader divides by sigma, so any positive value will do)
    uniforms = {"sigma": float(sigma) if sigma > 0 else 1.0, "radius": gaussian_radius(sigma)}
    fullscreen_pass(ctx, program, across, textures={"image": image}, uniforms={**uniforms, "axis_step": (1, 0)})
    fullscreen_pass(ctx, program, result, textures={"image": across}, uniforms={**uniforms, "axis_step": (0, 1)})


def premultiplied(color) -> tuple[float, float, float, float]:
    """A ColorProperty's straight RGBA (r, g, b, a) as premultiplied RGBA (r a, g a, b a, a)."""
    r, g, b, a = (float(v) for v in color)
    return (r * a, g * a, b * a, a)
