"""The shared parts of the ray casters (the contract: vgraph.gl.raycasting.raycaster_base).

Here: the pixel's ray (EntryExit, CameraRays), the volume and its sampling (VolumeSampling,
Sampling), compositing front to back with the one opacity correction (FrontToBack), the transfer
function (TransferFunctionLut), the iso level (IsoSurface, RawIsoSurface), empty-space skipping
(EmptySpace) and the background. Lighting and the gradients it needs are in
vgraph.gl.raycasting.light (Light, Gradients).
"""

from __future__ import annotations

from typing import Callable

from vgraph.gl.raycasting import ray_bounds
from vgraph.gl.raycasting.empty_space import BLOCK, WALK_BLOCK, SkipBlocks, block_grid_uniforms
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA, pixel_rays, vec
from vgraph.gl.raycasting.ray_bounds import RayBounds
from vgraph.gl.raycasting.raycaster_base import Binding, Component, Frame, in_modes
from vgraph.gl.raycasting.textures import TransferFunctionTexture, linear_sampler
from vgraph.image import Image
from vgraph.ports import Inport
from vgraph.properties import (BoolProperty, CameraProperty, ColorProperty, FloatProperty, OptionProperty,
                               TransferFunctionProperty)
from vgraph.transfer_function import TransferFunction
from vgraph.volume import PRECISIONS, Volume


class EntryExit(Component):
    """The pixel's ray between the EntryExitPoints images."""

    inports = (Inport("entry", Image), Inport("exit", Image))
    glsl = ("raycasting/pixel_ray.glsl",)

    def bind(self, frame: Frame) -> Binding:
        return Binding(textures={"entry_points": frame.entry, "exit_points": frame.exit})


def ray_main_missed(background, with_depth: bool) -> tuple:
    """What ray_main.glsl writes where a pixel's ray misses (RaycasterBase.draw's ``missed``): the
    background, and the depth output's no_depth(0) (depth_output.glsl)."""
    return (tuple(background), (1.0, 0.0, 0.0, 0.0)) if with_depth else (tuple(background),)


class CameraRays(Component):
    """The camera (link it to the EntryExitPoints'), the rays in world space and the depth output."""

    glsl = ("raycasting/ray.glsl", "raycasting/depth_output.glsl")

    def declare(self):
        return {"camera": CameraProperty(DEFAULT_CAMERA, doc="link it to the EntryExitPoints camera")}

    def bind(self, frame: Frame) -> Binding:
        size, camera = frame.size, frame.camera
        to_world_scale, to_world_offset = frame.geometry.texture_to_world
        rays = pixel_rays(camera, size)  # a tile's pixels: the whole picture's rays
        return Binding(uniforms={
            "texture_to_world_scale": vec(to_world_scale), "texture_to_world_offset": vec(to_world_offset),
            "world_length": frame.box_frame.scale,  # the depth output's distance in world units
            "view_projection": camera.view_projection(size[0] / size[1]),
            "view_forward": vec(camera.basis()[2]),
            **{name: rays[name] for name in ("viewport_size", "pixel_offset", "near_centre", "near_right",
                                             "near_up")}})


class VolumeSampling(Component):
    """The volume texture, sampled trilinearly through a sampler object whatever its own filter.
    ``volume_precision`` "16bit" samples float (and 32-bit integer) volumes from their 16-bit copy
    (Volume.at_precision: R16, llvmpipe's fastest format; normalised intensities within 7.6e-6).
    The frame's volume is that copy (frame_volume), so block ranges for skipping, gradient scales
    and the transfer function all see the values the shader samples."""

    glsl = ("raycasting/volume_sampling.glsl",)

    def declare(self):
        return {"volume_precision": OptionProperty(
            "full", choices=list(PRECISIONS),
            doc="full: the stored values; 16bit: float volumes as 16-bit codes over the value range "
                "(faster texture, error <= range / 131070)")}

    def frame_volume(self, volume: Volume) -> Volume:
        return volume.at_precision(self.processor.volume_precision)

    def bind(self, frame: Frame) -> Binding:
        volume = frame.volume
        scale, offset = volume.texture_scale_offset()
        return Binding(textures={"volume": volume.texture(frame.ctx)},
                       samplers={"volume": linear_sampler(frame.ctx)},
                       uniforms={"intensity_scale": float(scale), "intensity_offset": float(offset),
                                 "volume_dims": tuple(int(d) for d in volume.dims)})


class Sampling(Component):
    """Samples every min(spacing) / sampling_rate world units along the ray."""

    def declare(self):
        return {"sampling_rate": FloatProperty(1.0, min=0.05, max=16.0,
                                               doc="samples per voxel of the smallest spacing "
                                                   "(a world-space step)")}

    def bind(self, frame: Frame) -> Binding:
        return Binding(uniforms={"step_length": frame.min_spacing / self.processor.sampling_rate})


class FrontToBack(Component):
    """Front-to-back compositing: each sample's opacity corrected for the step, 1 - (1 - a)^(1 /
    sampling_rate) (the one writer of OPACITY_CORRECTION; with ``mode``, only in the
    ``corrected`` modes of that option, those that composite opacities), and the ray stopped once
    its opacity reaches ``early_termination``."""

    def __init__(self, mode: str | None = None, corrected: tuple[str, ...] | None = None,
                 early_termination: float = 0.99):
        self.mode, self.corrected, self.early_termination = mode, corrected, early_termination

    def declare(self):
        return {"early_termination": FloatProperty(self.early_termination, min=0.01, max=1.0,
                                                   doc="stop a ray once its opacity reaches this")}

    def opacity_exponent(self) -> float:
        return 1.0 / self.processor.sampling_rate

    def bind(self, frame: Frame) -> Binding:
        rate = self.processor.sampling_rate
        corrected = rate != 1.0 and in_modes(self.processor, self.mode, self.corrected)
        return Binding(defines={"OPACITY_CORRECTION": corrected},
                       uniforms={"opacity_exponent": self.opacity_exponent(),
                                 "early_termination": self.processor.early_termination})


# The palette's volume ray casters (RayCaster, BrickedRayCaster) start as ``vgraph run FILE`` does
# (vgraph.volume_network): the ``auto`` transfer function, placed by percentiles, shows any data set
# without knowing its units or being squeezed by an outlier voxel (the components' default is a ramp
# over the normalised range), shaded. Files of format version 2 and older keep the old defaults
# (vgraph.fileformat).
def palette_transfer_function() -> TransferFunctionProperty:
    return TransferFunctionProperty("auto", doc="RGBA over normalised intensity, data values or "
                                    "percentiles (a preset name or TF file also works); alpha per "
                                    "sample at rate 1; by default the auto preset")


def palette_shading() -> OptionProperty:
    return OptionProperty("blinn_phong", choices=["none", "blinn_phong"], doc="lighting of the samples or surface")


class TransferFunctionLut(Component):
    """The transfer function as a 4096-entry LUT texture, resolved for the volume."""

    glsl = ("raycasting/transfer_function.glsl",)
    DEFAULT = TransferFunction(points=[(0.0, 0.0, 0.0, 0.0, 0.0), (0.45, 0.85, 0.55, 0.3, 0.0),
                                       (0.55, 0.95, 0.8, 0.6, 0.4), (1.0, 1.0, 1.0, 1.0, 0.8)])

    def start(self) -> None:
        self.lut = TransferFunctionTexture()

    def declare(self):
        return {"transfer_function": TransferFunctionProperty(
            TransferFunctionLut.DEFAULT, doc="RGBA over normalised intensity, data values or "
            "percentiles (a preset name or TF file also works); alpha per sample at rate 1")}

    def bind(self, frame: Frame) -> Binding:
        texture = self.lut.update(frame.ctx, self.processor.transfer_function, frame.volume)
        return Binding(textures={"transfer_function": texture})


class IsoSurface(Component):
    """The iso level, a normalised intensity (0.5: the surface of every FunctionSelector volume)."""

    def declare(self):
        return {"iso_level": FloatProperty(0.5, min=0.0, max=1.0,
                                           doc="normalised intensity of the iso-surface")}

    def bind(self, frame: Frame) -> Binding:
        return Binding(uniforms={"iso_level": self.processor.iso_level})


class RawIsoSurface(IsoSurface):
    """The iso level handed to the shader as a texture value: near the level, raw values keep
    more digits than normalised ones (the curvature hit search)."""

    def bind(self, frame: Frame) -> Binding:
        scale, offset = frame.volume.texture_scale_offset()
        return Binding(uniforms={"raw_level": (self.processor.iso_level - offset) / scale})


SkipValues = Callable[[object, Frame], "tuple | None"]


class EmptySpace(Component):
    """Empty-space skipping over blocks (vgraph.gl.raycasting.empty_space) and, where empty blocks
    contribute nothing, ray bounds from the occupied ones (vgraph.gl.raycasting.ray_bounds).
    ``skip(processor, frame)`` gives (what they depend on, values(block_min, block_max)), or None
    when this frame's mode does not skip; with ``ray_bounds`` on, bounds are drawn when what they
    depend on is (kind, ...) with kind one of BOUNDED, where empty blocks contribute nothing (the
    RayCaster's dvr, first_hit and iso, the CurvatureVolumeRaycaster), not for mip (block maxima)
    or ray casters that do not say so (the CurvatureRaycaster's hit search also reads the exit
    point)."""

    glsl = ("raycasting/empty_space.glsl", "raycasting/ray_bounds.glsl")
    BOUNDED = ("opacity", "level")
    WALKED = ("maximum",)  # a ray visits every block (MIP): larger blocks (empty_space docstring)

    def __init__(self, skip: SkipValues):
        self.skip = skip

    def start(self) -> None:
        self.blocks = SkipBlocks()
        self.bounds = RayBounds()

    def declare(self):
        return {"empty_space_skipping": BoolProperty(True, doc="skip blocks that cannot contribute "
                                                               "(same image, faster)"),
                "ray_bounds": BoolProperty(False, doc="start and end each ray at the occupied blocks "
                                                      "(same image; pays where a group of pixels skips "
                                                      "work none of them needs, not on llvmpipe)")}

    def bind(self, frame: Frame) -> Binding:
        processor = self.processor
        texture = None
        wanted = self.skip(processor, frame) if processor.empty_space_skipping else None
        block = WALK_BLOCK if wanted is not None and wanted[0] in self.WALKED else BLOCK
        if wanted is not None:
            texture = self.blocks.texture(frame.ctx, frame.volume, *wanted, block=block)
        bounds = None
        if (processor.ray_bounds and texture is not None and isinstance(wanted[0], tuple)
                and wanted[0][0] in self.BOUNDED):
            bounds = self.bounds.texture(frame, self.blocks.key, self.blocks.values == 0.0)
        textures = {"blocks": texture} if texture is not None else {}
        if bounds is not None:
            textures["ray_bounds"] = bounds
        return Binding(defines={"SKIP_EMPTY_SPACE": texture is not None, "RAY_BOUNDS": bounds is not None},
                       textures=textures,
                       uniforms={**block_grid_uniforms(frame.volume, block),
                                 "ray_bounds_tile": ray_bounds.TILE})


class Background(Component):
    """The colour under the composited one."""

    glsl = ("raycasting/background.glsl",)

    def declare(self):
        return {"background": ColorProperty((0.0, 0.0, 0.0, 1.0))}

    def bind(self, frame: Frame) -> Binding:
        return Binding(uniforms={"background": tuple(self.processor.background)})
