"""The shared parts of the ray casters (the contract: vgraph.gl.raycasting.raycaster_base).

Here: the pixel's ray (EntryExit, CameraRays), the volume and its sampling (VolumeSampling,
Sampling), compositing front to back with the one opacity correction (FrontToBack), the transfer
functions of one volume or of n channels (TransferFunctionLut), the iso level (IsoSurface,
RawIsoSurface), empty-space skipping (EmptySpace) and the background. Lighting and the gradients
it needs are in vgraph.gl.raycasting.light (Light, Gradients).
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

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
    """Samples every min(spacing) / sampling_rate world units along the ray: the spacing of the
    frame's volume, or with ``over="all volumes"`` the smallest of all the frame's volumes (the
    MultiVolumeRayCaster's channels, so the finest channel is sampled at rate 1)."""

    OVER = ("volume", "all volumes")

    def __init__(self, over: str = "volume"):
        if over not in self.OVER:
            raise ValueError(f"Sampling(over={over!r}): one of {', '.join(self.OVER)}")
        self.over = over

    def declare(self):
        of = "" if self.over == "volume" else " of all volumes"
        return {"sampling_rate": FloatProperty(1.0, min=0.05, max=16.0,
                                               doc=f"samples per voxel of the smallest spacing{of} "
                                                   f"(a world-space step)")}

    def step_length(self, frame: Frame) -> float:
        """World units between samples (ray.glsl's step_length): ``frame.sample_stride`` steps of
        the sampling rate's."""
        spacing = frame.min_spacing if self.over == "volume" else finest_spacing(frame)
        return spacing / self.processor.sampling_rate * frame.sample_stride

    def bind(self, frame: Frame) -> Binding:
        return Binding(uniforms={"step_length": self.step_length(frame)})


def finest_spacing(frame: Frame) -> float:
    """The smallest spacing of all the frame's volumes."""
    return min(float(np.min(volume.spacing)) for volume in frame.volumes or (frame.volume,))


class FrontToBack(Component):
    """Front-to-back compositing: each sample's opacity corrected for the step, 1 - (1 - a)^(stride
    / sampling_rate) (``frame.sample_stride``; the one writer of OPACITY_CORRECTION; with
    ``mode``, only in the ``corrected`` modes of that option, those that composite opacities), and
    the ray stopped once its opacity reaches ``early_termination``."""

    def __init__(self, mode: str | None = None, corrected: tuple[str, ...] | None = None,
                 early_termination: float = 0.99):
        self.mode, self.corrected, self.early_termination = mode, corrected, early_termination

    def declare(self):
        return {"early_termination": FloatProperty(self.early_termination, min=0.01, max=1.0,
                                                   doc="stop a ray once its opacity reaches this")}

    def opacity_exponent(self, frame: Frame) -> float:
        """The step in samples at rate 1 (stride / sampling_rate): what the opacity of a sample,
        the TF's per sample at rate 1, is corrected by."""
        return 1.0 / self.processor.sampling_rate * frame.sample_stride

    def bind(self, frame: Frame) -> Binding:
        step_not_a_voxel = self.processor.sampling_rate != 1.0 or frame.sample_stride != 1
        corrected = step_not_a_voxel and in_modes(self.processor, self.mode, self.corrected)
        return Binding(defines={"OPACITY_CORRECTION": corrected},
                       uniforms={"opacity_exponent": self.opacity_exponent(frame),
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


def _ramp(r, g, b, low=0.2, high=0.8, alpha=0.6) -> TransferFunction:
    """A channel's default TF: transparent below ``low``, rising to ``alpha`` in one colour at ``high``."""
    return TransferFunction(points=[(0.0, r, g, b, 0.0), (low, r, g, b, 0.0), (high, r, g, b, alpha),
                                    (1.0, r, g, b, alpha)])


ChannelNumbers = Callable[[object, Frame], Sequence[int]]


class TransferFunctionLut(Component):
    """Transfer functions as 4096-entry LUT textures, each resolved for the volume it classifies.

    ``channels=1``: ``transfer_function`` of the frame's volume (raycasting/transfer_function.glsl).
    ``channels=n``: ``transfer_function1`` .. n, of the inports ``<inport>1`` .. n (as
    ``transfer_function_inports`` pairs them: the GUI shows each TF editor its volume's histogram),
    one hue per channel by default. ``connected(processor, frame)`` gives the numbers of the
    channels connected this frame, in the order of ``frame.volumes``: slot k holds the k-th of them,
    whatever its number (raycasting/channel_transfer_functions.glsl), and the define CHANNELS says
    how many there are. Each TF's alpha is per sample at rate 1 of its own channel: the slots'
    ``opacity_reference`` scales FrontToBack's exponent from the finest channel (Sampling's
    ``over="all volumes"``) to each channel's spacing."""

    DEFAULT = TransferFunction(points=[(0.0, 0.0, 0.0, 0.0, 0.0), (0.45, 0.85, 0.55, 0.3, 0.0),
                                       (0.55, 0.95, 0.8, 0.6, 0.4), (1.0, 1.0, 1.0, 1.0, 0.8)])
    # One hue per channel, as microscopy viewers colour channels.
    CHANNEL_DEFAULTS = (_ramp(1.0, 0.55, 0.15), _ramp(0.2, 0.6, 1.0), _ramp(0.3, 0.95, 0.35),
                        _ramp(0.95, 0.3, 0.9))

    def __init__(self, channels: int = 1, inport: str = "volume", connected: ChannelNumbers | None = None):
        if not 1 <= channels <= len(self.CHANNEL_DEFAULTS):
            raise ValueError(f"TransferFunctionLut(channels={channels}): 1 to {len(self.CHANNEL_DEFAULTS)}")
        if channels > 1 and connected is None:
            raise ValueError("TransferFunctionLut(channels > 1) needs connected(processor, frame)")
        self.channels, self.inport, self.connected = channels, inport, connected
        self.glsl = (("raycasting/transfer_function.glsl",) if channels == 1
                     else ("raycasting/channel_transfer_functions.glsl",))

    @property
    def transfer_function_inports(self) -> dict[str, str]:
        """Which inport each TF property classifies."""
        if self.channels == 1:
            return {"transfer_function": self.inport}
        return {f"transfer_function{n}": f"{self.inport}{n}" for n in range(1, self.channels + 1)}

    def start(self) -> None:
        self.luts = {number: TransferFunctionTexture() for number in range(1, self.channels + 1)}
        self.lut = self.luts[1]  # the one LUT of channels=1 (the RayCaster's skipping reads its alpha)

    def declare(self):
        if self.channels == 1:
            return {"transfer_function": TransferFunctionProperty(
                TransferFunctionLut.DEFAULT, doc="RGBA over normalised intensity, data values or "
                "percentiles (a preset name or TF file also works); alpha per sample at rate 1")}
        return {name: TransferFunctionProperty(
                    self.CHANNEL_DEFAULTS[number - 1], label=f"Transfer function ({inport})",
                    doc=f"of {inport}" + (" (alpha per sample at rate 1)" if number == 1 else ""))
                for number, (name, inport) in enumerate(self.transfer_function_inports.items(), start=1)}

    def bind(self, frame: Frame) -> Binding:
        if self.channels == 1:
            texture = self.lut.update(frame.ctx, self.processor.transfer_function, frame.volume)
            return Binding(textures={"transfer_function": texture})
        numbers = list(self.connected(self.processor, frame))
        volumes = frame.volumes
        textures = {f"transfer_function{slot}": self.luts[number].update(
                        frame.ctx, getattr(self.processor, f"transfer_function{number}"), volume)
                    for slot, (number, volume) in enumerate(zip(numbers, volumes, strict=True), start=1)}
        finest = finest_spacing(frame)
        reference = np.asarray([finest / float(np.min(volume.spacing)) for volume in volumes], dtype=np.float32)
        return Binding(defines={"CHANNELS": len(volumes)}, textures=textures,
                       uniforms={"opacity_reference": reference})


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
