"""Lighting of the ray casters (Inácio 2009 ch. 4.3): Blinn-Phong with a headlight or a directional
light (Light), and the gradients it needs as normals (Gradients), both components
(vgraph.gl.raycasting.raycaster_base); shading_uniforms also serves the GeometryRenderer."""

from __future__ import annotations

import numpy as np

from vgraph.errors import VGraphError
from vgraph.gl.raycasting.geometry import vec
from vgraph.gl.raycasting.gradient_volume import gradient_texture, holds_values
from vgraph.gl.raycasting.raycaster_base import Binding, Component, Frame, in_modes
from vgraph.gl.raycasting.textures import linear_sampler
from vgraph.numerics.reference_raycast import GRADIENT_EPSILON
from vgraph.properties import FloatProperty, OptionProperty, VectorProperty


def shading_uniforms(owner, min_spacing: float, frame=None) -> dict[str, object]:
    """Uniforms of raycasting/shading.glsl from ``owner``'s lighting properties; gradients at or
    below GRADIENT_EPSILON / min(spacing) leave a sample unshaded, as in the CPU reference. The
    light direction (world) is turned into ``frame`` (a vgraph.box_frame.BoxFrame) where the
    gradients are."""
    light = np.asarray(owner.light_direction, dtype=np.float64)
    largest = np.abs(light).max()
    if owner.light == "direction" and not largest > 0.0:
        raise VGraphError(f"{owner.id}.light_direction must not be zero, got {list(light)}")
    light = light / largest if largest > 0.0 else light  # scaled first: |(1e308,)*3| overflows
    if frame is not None:
        light = frame.directions(light)
    return {"gradient_epsilon": GRADIENT_EPSILON / min_spacing,
            "light_direction": tuple(float(v) for v in light / max(np.linalg.norm(light), 1e-300)),
            "ambient": owner.ambient, "diffuse": owner.diffuse, "specular": owner.specular,
            "shininess": owner.shininess}


class Light(Component):
    """Blinn-Phong shading with a headlight or a directional light. A frame is lit when
    ``shading`` is not none and, given ``mode``, that option of the processor is one of
    ``shaded_modes`` (the RayCaster lights dvr and iso, not mip)."""

    glsl = ("raycasting/shading.glsl",)

    def __init__(self, mode: str | None = None, shaded_modes: tuple[str, ...] | None = None):
        self.mode, self.shaded_modes = mode, shaded_modes

    def declare(self):
        return {"shading": OptionProperty("none", choices=["none", "blinn_phong"],
                                          doc="lighting of the samples or surface"),
                "light": OptionProperty("headlight", choices=["headlight", "direction"],
                                        doc="headlight: light from the viewer; direction: light_direction"),
                "light_direction": VectorProperty((1.0, 1.0, 1.0), doc="world-space direction towards the light"),
                "ambient": FloatProperty(0.3, min=0.0, max=1.0),
                "diffuse": FloatProperty(0.7, min=0.0, max=1.0),
                "specular": FloatProperty(0.2, min=0.0, max=1.0),
                "shininess": FloatProperty(32.0, min=1.0, max=512.0)}

    def shades(self) -> bool:
        return self.processor.shading != "none" and in_modes(self.processor, self.mode, self.shaded_modes)

    def bind(self, frame: Frame) -> Binding:
        if not self.shades():
            return Binding()
        processor = self.processor
        return Binding(defines={"SHADING_BLINN_PHONG": True, "LIGHT_HEADLIGHT": processor.light == "headlight"},
                       uniforms=shading_uniforms(processor, frame.min_spacing, frame.box_frame))


# Raw texture differences -> normalised intensity per world unit: divide by this many spacings.
DERIVATIVE_SPACINGS = {"forward": 1.0, "backward": 1.0, "central": 2.0, "sobel": 32.0}


class Gradients(Component):
    """The normals of a lit frame: finite differences of the sampled field (``derivatives`` one
    of ``choices``: forward, backward, central, sobel; none; precomputed: central differences at
    the voxels, computed once per volume, vgraph.gl.raycasting.gradient_volume). Binds nothing
    for an unlit frame (``frame.lit``); a lit one without derivatives is refused by name."""

    glsl = ("raycasting/gradients.glsl",)
    DOC = "finite differences of the shading normals"

    def __init__(self, choices: tuple[str, ...] = ("central", "forward", "backward", "sobel"),
                 doc: str = DOC):
        self.choices, self.doc = choices, doc

    def declare(self):
        return {"derivatives": OptionProperty("central", choices=list(self.choices), doc=self.doc)}

    def check(self) -> None:
        """Shading without derivatives is refused, lit frame or not (a mode change would light it)."""
        processor = self.processor
        if processor.shading != "none" and processor.derivatives == "none":
            raise VGraphError(f"{processor.id}.shading: {processor.shading} needs derivatives; set "
                              f"{processor.id}.derivatives to central (or forward, backward, sobel, "
                              f"precomputed) or {processor.id}.shading to none")

    def defines(self, derivatives: str | None = None) -> dict[str, bool]:
        """GRADIENT_<derivatives>, for a lit frame (``derivatives``: the processor's unless given;
        the bricks draw precomputed as central, vgraph.bricks.sampling)."""
        return {f"GRADIENT_{(derivatives or self.processor.derivatives).upper()}": True}

    def uniforms(self, intensity_scale: float, voxel, spacing, derivatives: str | None = None) -> dict[str, object]:
        """The finite differences' uniforms for a grid of texture-space ``voxel`` and world
        ``spacing`` (a brick's level has its own); ``derivatives`` as for defines()."""
        spacings = DERIVATIVE_SPACINGS[derivatives or self.processor.derivatives]
        return {"voxel_step": vec(voxel), "gradient_scale": vec(intensity_scale / (spacings * spacing))}

    def bind(self, frame: Frame) -> Binding:
        self.check()
        if not frame.lit:
            return Binding()
        binding = Binding(self.defines())
        if self.processor.derivatives == "precomputed":
            texture, scale = gradient_texture(frame.ctx, frame.volume)
            binding.defines["GRADIENT_HOLDS_VALUE"] = holds_values(frame.volume)
            return binding.merge(Binding(textures={"gradients": texture},
                                         samplers={"gradients": linear_sampler(frame.ctx)},
                                         uniforms={"gradient_scale": vec(scale)}))
        scale, _ = frame.volume.texture_scale_offset()
        return binding.merge(Binding(uniforms=self.uniforms(float(scale), 1.0 / frame.geometry.dims,
                                                            frame.geometry.spacing)))
