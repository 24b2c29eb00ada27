"""Output images of the renderers, kept across evaluations."""

from __future__ import annotations

import moderngl

from vgraph.gl_context import bind_default_framebuffer
from vgraph.image import Image


class RenderTargets:
    """Output images kept across evaluations (rewritten in place while the size stays the same) and
    one framebuffer with all of them attached, for shaders with several outputs."""

    def __init__(self, count: int):
        self.count = count
        self.images: list[Image] = []
        self.framebuffer = None

    def ensure(self, ctx: moderngl.Context, size) -> list[Image]:
        size = tuple(int(v) for v in size)
        live = all(image.texture is not None and image.ctx is ctx for image in self.images)
        if not (self.images and live and self.images[0].size == size):
            if live:
                self.release()
            # (Objects of a replaced context went with it and must not be released again.)
            self.images, self.framebuffer = [], None
            self.images = [Image.empty(ctx, size) for _ in range(self.count)]
            self.framebuffer = ctx.framebuffer(color_attachments=[i.texture for i in self.images])
        return self.images

    @property
    def size(self) -> tuple[int, int]:
        return self.images[0].size

    def release(self) -> None:
        for image in self.images:
            if image.texture is not None:
                image.release()
        if self.framebuffer is not None:
            bind_default_framebuffer(self.framebuffer.ctx)
            self.framebuffer.release()
        self.images, self.framebuffer = [], None

