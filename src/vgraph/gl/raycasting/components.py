"""Ray casters built from components (in the spirit of Inviwo's StandardVolumeRaycaster).

A component is one part of a ray caster: the properties it declares (once, here), the GLSL file(s)
it stands for, and what it binds for one frame: defines, textures (with their samplers) and
uniforms. A ray caster lists its components and adds only what is truly its own::

    class RayCaster(RaycasterBase):
        components = (EntryExit, CameraRays, VolumeSampling, Sampling, FrontToBack,
                      TransferFunctionLut, IsoSurface, Light, EmptySpace, Background)
        compositing = OptionProperty(...)          # its own properties, as on any processor

        def process(self, volume, entry, exit):
            frame = self.frame(volume, entry, exit)
            self.draw(frame, SHADER, targets, defines={...})

Conventions:
- Properties of the listed components become the class's properties, after those of its body; a
  property the body declares under the same name replaces the component's (another default).
- A component object lives as long as its processor (``self.parts[Component]``) and keeps what must
  survive between frames (LUT and block textures). ``bind(frame)`` returns a Binding; ``draw``
  merges the bindings of the parts a pass uses with the processor's own, the processor's last.
- Textures are bound by name and the uniforms set strictly (vgraph.gl.passes): a component binds
  exactly the uniforms its GLSL part declares.
- Every frame is rendered with the program of its define set, looked up in the program cache
  (compiled once per set): property changes need no other rebuilding (docs/architecture.md).
- A frame is drawn in the normalised frame of the volume's box (vgraph.gl.raycasting.framed_view):
  ``frame.volume``, ``frame.geometry`` and ``frame.camera`` are in it, so every length a component
  binds is in its units; only the depth output's distance is scaled back to world units
  (``world_length``). For an ordinary box that frame is the world itself. A ray caster whose
  outputs or properties hold world lengths the frame would change says ``frames_extreme_boxes =
  False`` and refuses extreme boxes by name.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import moderngl

from vgraph.box_frame import BoxFrame
from vgraph.camera import Camera
from vgraph.errors import VGraphError
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.empty_space import BLOCK, WALK_BLOCK, SkipBlocks, block_grid_uniforms
from vgraph.gl.raycasting.framed_view import framed_view
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA, VolumeGeometry, pixel_rays, vec
from vgraph.gl.raycasting.light import shading_uniforms
from vgraph.gl.raycasting import ray_bounds
from vgraph.gl.raycasting.ray_bounds import RayBounds
from vgraph.gl.raycasting.textures import TransferFunctionTexture, linear_sampler
from vgraph.gl.shaders import programs
from vgraph.image import Image
from vgraph.processor import Processor
from vgraph.properties import (BoolProperty, CameraProperty, ColorProperty, FloatProperty, OptionProperty,
                               Property, TransferFunctionProperty, VectorProperty)
from vgraph.transfer_function import TransferFunction
from vgraph.volume import PRECISIONS, Volume


@dataclass
class Frame:
    """One evaluation of a ray caster: its inputs and the concrete camera, in the normalised frame
    ``box_frame`` of the volumes' box (the world itself for an ordinary box); ``volumes`` are all
    the volumes of the view in it (``volume``, at its precision, is the first)."""

    ctx: moderngl.Context
    volume: Volume
    entry: Image
    exit: Image
    camera: Camera
    geometry: VolumeGeometry
    box_frame: BoxFrame = BoxFrame()
    volumes: tuple[Volume, ...] = ()

    @property
    def size(self) -> tuple[int, int]:
        return self.entry.size

    @property
    def min_spacing(self) -> float:
        return float(self.geometry.spacing.min())


@dataclass
class Binding:
    """What a component contributes to a pass."""

    defines: dict[str, bool] = field(default_factory=dict)
    textures: dict[str, object] = field(default_factory=dict)
    samplers: dict[str, object] = field(default_factory=dict)
    uniforms: dict[str, object] = field(default_factory=dict)

    def merge(self, other: "Binding") -> "Binding":
        return Binding({**self.defines, **other.defines}, {**self.textures, **other.textures},
                       {**self.samplers, **other.samplers}, {**self.uniforms, **other.uniforms})


MISSED_FILL_SHADER = "missed_fill.frag.glsl"


class Component:
    """Base of the components: no properties, binds nothing."""

    glsl: ClassVar[tuple[str, ...]] = ()

    def __init__(self, processor: "RaycasterBase"):
        self.processor = processor

    @staticmethod
    def declare() -> dict[str, Property]:
        """Fresh property declarations, by name (each processor class gets its own objects)."""
        return {}

    def bind(self, frame: Frame) -> Binding:
        return Binding()


class RaycasterBase(Processor):
    """A processor made of components (see the module docstring). Not a processor type itself."""

    components: ClassVar[tuple[type[Component], ...]] = ()
    # Whether an extreme box may be drawn in its normalised frame (module docstring).
    frames_extreme_boxes: ClassVar[bool] = True

    def __init_subclass__(cls, **kwargs):
        for component in cls.__dict__.get("components", ()):
            for name, prop in component.declare().items():
                if name not in cls.__dict__:  # the body's own declaration wins
                    prop.__set_name__(cls, name)
                    setattr(cls, name, prop)
        super().__init_subclass__(**kwargs)

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self.parts = {component: component(self) for component in self.components}
        self.passes: list[tuple[str, dict]] = []  # (shader, defines) of each pass of the last frame

    def frame(self, volume: Volume, entry: Image, exit: Image, volumes=None) -> Frame:
        """The frame of one process(): checks that the entry and exit images belong together and
        resolves the camera on the box of ``volumes`` (default: ``volume`` alone; the union when
        several), in that box's normalised frame (``view_camera`` keeps the camera in world units
        for the GUI)."""
        if entry.size != exit.size:
            raise VGraphError(f"entry image is {entry.size[0]}x{entry.size[1]} but exit image is "
                              f"{exit.size[0]}x{exit.size[1]}; connect both to one EntryExitPoints")
        view = framed_view(self.camera, volumes or (volume,), entry.size, self.id)
        if not (view.frame.is_identity or self.frames_extreme_boxes):
            raise VGraphError(self.extreme_box_refusal(volume))
        self.view_camera = view.world_camera
        self.passes = []
        volume = view.volumes[0]
        if VolumeSampling in self.parts:  # the volume at the precision it is sampled at, for every part
            volume = volume.at_precision(self.volume_precision)
        return Frame(self.gl, volume, entry, exit, view.camera, VolumeGeometry.of(volume), view.frame,
                     view.volumes)

    def extreme_box_refusal(self, volume: Volume) -> str:
        """Why this ray caster does not draw ``volume`` (frames_extreme_boxes False)."""
        low, high = VolumeGeometry.of(volume).box
        return (f"{self.id}.volume: {volume.source or 'the volume'} spans {low.tolist()} .. "
                f"{high.tolist()}, a box this ray caster cannot draw: its outputs and properties are "
                f"in world units, which float32 does not hold for a box that small, that large or "
                f"that far from the origin; give the VolumeSource a spacing and origin near 1 "
                f"(the RayCaster draws such boxes as they are)")

    def draw(self, frame: Frame, shader: str, target, parts=None, own: Binding | None = None,
             missed: tuple | None = None) -> None:
        """One fullscreen pass of ``shader`` into ``target`` with the bindings of ``parts`` (by
        default all components) and the processor's ``own`` (which override them). ``missed``: what
        the shader writes into each of the target's images where the pixel's ray misses; given, a
        trivial pass writes these everywhere (shaders/missed_fill.frag.glsl says why not a clear)
        and the pass draws only inside the entry image's ``covered`` rectangle."""
        binding = Binding()
        for component in parts if parts is not None else self.components:
            binding = binding.merge(self.parts[component].bind(frame))
        if own is not None:
            binding = binding.merge(own)
        program = programs.program(frame.ctx, FULLSCREEN_VERTEX_SHADER, shader, binding.defines,
                                   processor=self.id)
        covered = frame.entry.covered if missed is not None else None
        if covered is not None:  # outside, the values without the shader (on llvmpipe not free)
            fill = programs.program(frame.ctx, FULLSCREEN_VERTEX_SHADER, MISSED_FILL_SHADER, {},
                                    processor=self.id)
            self.passes.append((MISSED_FILL_SHADER, {}))
            fullscreen_pass(frame.ctx, fill, target, uniforms={f"missed{i}": v for i, v in enumerate(missed)})
            target.framebuffer.scissor = covered
        self.passes.append((shader, binding.defines))
        try:
            fullscreen_pass(frame.ctx, program, target, binding.textures, binding.uniforms,
                            samplers=binding.samplers)
        finally:
            if covered is not None:
                target.framebuffer.scissor = None


# --- the components -------------------------------------------------------------------------------
class EntryExit(Component):
    """The pixel's ray between the EntryExitPoints images."""

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

    @staticmethod
    def declare():
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
    The frame's volume is that copy (RaycasterBase.frame), so block ranges for skipping, gradient
    scales and the transfer function all see the values the shader samples."""

    glsl = ("raycasting/volume_sampling.glsl",)

    @staticmethod
    def declare():
        return {"volume_precision": OptionProperty(
            "full", choices=list(PRECISIONS),
            doc="full: the stored values; 16bit: float volumes as 16-bit codes over the value range "
                "(faster texture, error <= range / 131070)")}

    def bind(self, frame: Frame) -> Binding:
        volume = frame.volume
        scale, offset = volume.texture_scale_offset()
        return Binding(textures={"volume": volume.texture(frame.ctx)},
                       samplers={"volume": linear_sampler(frame.ctx)},
                       uniforms={"intensity_scale": float(scale), "intensity_offset": float(offset),
                                 "volume_dims": tuple(int(d) for d in volume.dims)})


class Sampling(Component):
    """Samples every min(spacing) / sampling_rate world units along the ray."""

    @staticmethod
    def declare():
        return {"sampling_rate": FloatProperty(1.0, min=0.05, max=16.0,
                                               doc="samples per voxel of the smallest spacing "
                                                   "(a world-space step)")}

    def bind(self, frame: Frame) -> Binding:
        return Binding(uniforms={"step_length": frame.min_spacing / self.processor.sampling_rate})


class FrontToBack(Component):
    """Front-to-back compositing: each sample's opacity corrected for the step, 1 - (1 - a)^(1 /
    sampling_rate), and the ray stopped once its opacity reaches ``early_termination``."""

    @staticmethod
    def declare():
        return {"early_termination": FloatProperty(0.99, min=0.01, max=1.0,
                                                   doc="stop a ray once its opacity reaches this")}

    def bind(self, frame: Frame) -> Binding:
        rate = self.processor.sampling_rate
        return Binding(defines={"OPACITY_CORRECTION": rate != 1.0},
                       uniforms={"opacity_exponent": 1.0 / rate,
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

    def __init__(self, processor):
        super().__init__(processor)
        self.lut = TransferFunctionTexture()

    @staticmethod
    def declare():
        return {"transfer_function": TransferFunctionProperty(
            TransferFunctionLut.DEFAULT, doc="RGBA over normalised intensity, data values or "
            "percentiles (a preset name or TF file also works); alpha per sample at rate 1")}

    def bind(self, frame: Frame) -> Binding:
        texture = self.lut.update(frame.ctx, self.processor.transfer_function, frame.volume)
        return Binding(textures={"transfer_function": texture})


class IsoSurface(Component):
    """The iso level, a normalised intensity (0.5: the surface of every FunctionSelector volume)."""

    @staticmethod
    def declare():
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


class Light(Component):
    """Blinn-Phong shading with a headlight or a directional light (Inácio 2009 ch. 4.3). The
    processor's ``shaded()`` says whether this frame is shaded."""

    glsl = ("raycasting/shading.glsl",)

    @staticmethod
    def declare():
        return {"shading": OptionProperty("none", choices=["none", "blinn_phong"],
                                          doc="lighting of the samples or surface"),
                "light": OptionProperty("headlight", choices=["headlight", "direction"],
                                        doc="headlight: light from the viewer; direction: light_direction"),
                "light_direction": VectorProperty((1.0, 1.0, 1.0), doc="world-space direction towards the light"),
                "ambient": FloatProperty(0.3, min=0.0, max=1.0),
                "diffuse": FloatProperty(0.7, min=0.0, max=1.0),
                "specular": FloatProperty(0.2, min=0.0, max=1.0),
                "shininess": FloatProperty(32.0, min=1.0, max=512.0)}

    def bind(self, frame: Frame) -> Binding:
        processor = self.processor
        if not processor.shaded():
            return Binding()
        return Binding(defines={"SHADING_BLINN_PHONG": True, "LIGHT_HEADLIGHT": processor.light == "headlight"},
                       uniforms=shading_uniforms(processor, frame.min_spacing, frame.box_frame))


class EmptySpace(Component):
    """Empty-space skipping over blocks (vgraph.gl.raycasting.empty_space) and, where empty blocks
    contribute nothing, ray bounds from the occupied ones (vgraph.gl.raycasting.ray_bounds). The
    processor's ``skip_values(frame)`` gives (what they depend on, values(block_min, block_max)), or
    None when this frame's mode does not skip; with ``ray_bounds`` on, bounds are drawn when what
    they depend on is (kind, ...) with kind one of BOUNDED, where empty blocks contribute nothing
    (the RayCaster's dvr, first_hit and iso, the CurvatureVolumeRaycaster), not for mip (block
    maxima) or ray casters that do not say so (the CurvatureRaycaster's hit search also reads the
    exit point)."""

    glsl = ("raycasting/empty_space.glsl", "raycasting/ray_bounds.glsl")
    BOUNDED = ("opacity", "level")
    WALKED = ("maximum",)  # a ray visits every block (MIP): larger blocks (empty_space docstring)

    def __init__(self, processor):
        super().__init__(processor)
        self.blocks = SkipBlocks()
        self.bounds = RayBounds()

    @staticmethod
    def declare():
        return {"empty_space_skipping": BoolProperty(True, doc="skip blocks that cannot contribute "
                                                               "(same image, faster)"),
                "ray_bounds": BoolProperty(False, doc="start and end each ray at the occupied blocks "
                                                      "(same image; pays where a group of pixels skips "
                                                      "work none of them needs, not on llvmpipe)")}

    def bind(self, frame: Frame) -> Binding:
        texture = None
        wanted = self.processor.skip_values(frame) if self.processor.empty_space_skipping else None
        block = WALK_BLOCK if wanted is not None and wanted[0] in self.WALKED else BLOCK
        if wanted is not None:
            texture = self.blocks.texture(frame.ctx, frame.volume, *wanted, block=block)
        bounds = None
        if (self.processor.ray_bounds and texture is not None and isinstance(wanted[0], tuple)
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

    @staticmethod
    def declare():
        return {"background": ColorProperty((0.0, 0.0, 0.0, 1.0))}

    def bind(self, frame: Frame) -> Binding:
        return Binding(uniforms={"background": tuple(self.processor.background)})
