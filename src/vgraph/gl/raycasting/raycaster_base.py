"""The component contract of the ray casters (after Inviwo's ShaderComponentProcessorBase).

A component is one part of a ray caster. It declares, once:

- ``inports``: the ports it reads (EntryExit: ``entry`` and ``exit``);
- ``declare()``: its properties, which become the processor's;
- ``glsl``: its GLSL segments, which ``draw()`` includes ahead of the processor's own shader, in
  the order of the components (a processor's shader includes only its own parts);
- ``bind(frame)``: what it binds for one frame, a Binding of defines, textures (with samplers) and
  uniforms: exactly the uniforms its GLSL declares (vgraph.gl.passes sets them strictly). What
  the frame's other parts decide comes with the frame (``frame.lit``: the Light's say;
  ``frame.sample_stride``: the sampling's, a drag's single pass stepping coarser).

What a component depends on is given when it is built (``Light(mode="compositing",
shaded_modes=("dvr", "iso"))``, ``EmptySpace(skip=skip_values)``), never looked up on the
processor. A ray caster is the list of its components plus its own part::

    class RayCaster(RaycasterBase):
        components = (EntryExit(), CameraRays(), VolumeSampling(), Sampling(), ...)
        compositing = OptionProperty(...)          # its own properties, as on any processor

        def process(self, volume, entry, exit):
            frame = self.frame(volume, entry, exit)
            self.draw(frame, SHADER, targets, own=Binding(defines={...}))

Conventions:
- The processor's own inports come first, then its components' in their order; its own property
  of a component's name replaces the component's (another default).
- The listed components are configurations; each processor gets its own copies
  (``self.parts[Type]``, Component.built_for), which keep what must survive between frames (LUT
  and block textures).
- ``draw`` merges the bindings of the parts a pass uses with the processor's own, the processor's
  last, and draws with the program of that define set (compiled once per set, vgraph.gl.shaders).
- A sampling component may draw the frame itself, in several passes, each through ``binding()``,
  ``program()`` or ``draw()`` with the parts it names: BrickSampling (vgraph.bricks.sampling), a
  pass per brick and a resolve pass; the RayCaster draws through it or VolumeSampling by frame.
- A frame is drawn in the normalised frame of the volume's box (vgraph.gl.raycasting.framed_view):
  ``frame.volume``, ``frame.geometry`` and ``frame.camera`` are in it, so every length a component
  binds is in its units; only the depth output's distance is scaled back to world units
  (``world_length``). For an ordinary box that frame is the world itself. A ray caster whose
  outputs or properties hold world lengths the frame would change says ``frames_extreme_boxes =
  False`` and refuses extreme boxes by name.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import ClassVar, NamedTuple

import moderngl

from vgraph.box_frame import BoxFrame
from vgraph.camera import Camera
from vgraph.errors import VGraphError
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.framed_view import framed_view
from vgraph.gl.raycasting.geometry import VolumeGeometry
from vgraph.gl.shaders import programs
from vgraph.image import Image
from vgraph.ports import Inport
from vgraph.processor import Processor
from vgraph.properties import Property
from vgraph.volume import Volume

MISSED_FILL_SHADER = "missed_fill.frag.glsl"


@dataclass
class Frame:
    """One evaluation of a ray caster: its inputs and the concrete camera, in the normalised frame
    ``box_frame`` of the volumes' box (the world itself for an ordinary box); ``volumes`` are all
    the volumes of the view in it (``volume``, at its precision, is the first); ``lit``: whether
    the frame is lit (the processor's shaded(), which its Light says), for the parts that bind
    only for lit frames (Gradients); ``sample_stride``: steps of ``step_length`` per sample, 1
    but in a drag's single-pass frame of bricks (vgraph.bricks.coarse_step), whose samples
    Sampling spaces and FrontToBack corrects for."""

    ctx: moderngl.Context
    volume: Volume
    entry: Image
    exit: Image
    camera: Camera
    geometry: VolumeGeometry
    box_frame: BoxFrame = BoxFrame()
    volumes: tuple[Volume, ...] = ()
    lit: bool = False
    sample_stride: int = 1

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


class Pass(NamedTuple):
    """One pass of the last frame: its shader, define set and the GLSL included ahead of it
    (``vgraph.gl.shaders.compose(shader, defines, includes=includes)`` is what was compiled)."""

    shader: str
    defines: dict
    includes: tuple[str, ...] = ()


class Component:
    """Base of the components: no ports, no properties, no GLSL, binds nothing."""

    inports: ClassVar[tuple[Inport, ...]] = ()
    glsl: ClassVar[tuple[str, ...]] = ()
    processor: "RaycasterBase | None" = None  # set on the processor's own copy (built_for)

    def declare(self) -> dict[str, Property]:
        """Fresh property declarations, by name (each processor class gets its own objects)."""
        return {}

    def built_for(self, processor: "RaycasterBase") -> "Component":
        """This component's copy for ``processor``: the same configuration, fresh state."""
        part = copy.copy(self)
        part.processor = processor
        part.start()
        return part

    def start(self) -> None:
        """Make the state a processor's copy keeps between frames (textures); none by default."""

    def frame_volume(self, volume: Volume) -> Volume:
        """The volume every part of a frame sees (VolumeSampling: at its precision)."""
        return volume

    def shades(self) -> bool:
        """Whether this frame is lit (the Light component says; the others do not light)."""
        return False

    def bind(self, frame: Frame) -> Binding:
        return Binding()


def in_modes(processor, mode: str | None, modes: tuple[str, ...] | None) -> bool:
    """Whether a component configured for ``modes`` of the processor's option ``mode`` applies
    now (always when not configured so)."""
    return mode is None or modes is None or getattr(processor, mode) in modes


class RaycasterBase(Processor):
    """A processor made of components (see the module docstring). Not a processor type itself."""

    components: ClassVar[tuple[Component, ...]] = ()
    # Whether an extreme box may be drawn in its normalised frame (module docstring).
    frames_extreme_boxes: ClassVar[bool] = True

    def __init_subclass__(cls, **kwargs):
        components = cls.__dict__.get("components", ())
        for component in components:
            if not isinstance(component, Component):
                raise TypeError(f"{cls.__name__}.components lists {component!r}: list components "
                                f"built with their dependencies, e.g. Light(), not the class")
            for name, prop in component.declare().items():
                if name not in cls.__dict__:  # the body's own declaration wins
                    prop.__set_name__(cls, name)
                    setattr(cls, name, prop)
        if components:
            own = list(cls.__dict__.get("inports", cls.inports))
            names = {port.name for port in own}
            cls.inports = own + [port for component in components for port in component.inports
                                 if port.name not in names]
        super().__init_subclass__(**kwargs)

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self.parts = {type(component): component.built_for(self) for component in self.components}
        self.passes: list[Pass] = []  # the passes of the last frame

    def shaded(self) -> bool:
        """Whether this frame is lit (its Light component says, by its configuration)."""
        return any(part.shades() for part in self.parts.values())

    def frame(self, volume: Volume, entry: Image, exit: Image, volumes=None, parts=None) -> Frame:
        """The frame of one process(): checks that the entry and exit images belong together and
        resolves the camera on the box of ``volumes`` (default: ``volume`` alone; the union when
        several), in that box's normalised frame (``view_camera`` keeps the camera in world units
        for the GUI); the frame's volume is the one ``parts`` (default: all) see (frame_volume)."""
        if entry.size != exit.size:
            raise VGraphError(f"entry image is {entry.size[0]}x{entry.size[1]} but exit image is "
                              f"{exit.size[0]}x{exit.size[1]}; connect both to one EntryExitPoints")
        view = framed_view(self.camera, volumes or (volume,), entry.size, self.id)
        if not (view.frame.is_identity or self.frames_extreme_boxes):
            raise VGraphError(self.extreme_box_refusal(volume))
        self.view_camera = view.world_camera
        self.passes = []
        volume = view.volumes[0]
        for part in self.used_parts(parts):
            volume = part.frame_volume(volume)
        return Frame(self.gl, volume, entry, exit, view.camera, VolumeGeometry.of(volume), view.frame,
                     view.volumes, lit=self.shaded())

    def extreme_box_refusal(self, volume: Volume) -> str:
        """Why this ray caster does not draw ``volume`` (frames_extreme_boxes False)."""
        low, high = VolumeGeometry.of(volume).box
        return (f"{self.id}.volume: {volume.source or 'the volume'} spans {low.tolist()} .. "
                f"{high.tolist()}, a box this ray caster cannot draw: its outputs and properties are "
                f"in world units, which float32 does not hold for a box that small, that large or "
                f"that far from the origin; give the VolumeSource a spacing and origin near 1 "
                f"(the RayCaster draws such boxes as they are)")

    def used_parts(self, parts=None) -> list[Component]:
        """This processor's copies of ``parts`` (components or their types; default: all)."""
        if parts is None:
            return list(self.parts.values())
        return [self.parts[part if isinstance(part, type) else type(part)] for part in parts]

    def binding(self, frame: Frame, parts=None, own: Binding | None = None) -> Binding:
        """The merged bindings of ``parts`` (default: all) and the processor's ``own`` (last)."""
        binding = Binding()
        for part in self.used_parts(parts):
            binding = binding.merge(part.bind(frame))
        return binding.merge(own) if own is not None else binding

    def program(self, frame: Frame, shader: str, defines: dict, parts=None) -> moderngl.Program:
        """The program of ``shader`` with the GLSL of ``parts`` (default: all) included ahead."""
        includes = tuple(dict.fromkeys(name for part in self.used_parts(parts) for name in part.glsl))
        self.passes.append(Pass(shader, defines, includes))
        return programs.program(frame.ctx, FULLSCREEN_VERTEX_SHADER, shader, defines, processor=self.id,
                                includes=includes)

    def draw(self, frame: Frame, shader: str, target, parts=None, own: Binding | None = None,
             missed: tuple | None = None) -> None:
        """One fullscreen pass of ``shader`` into ``target`` with the bindings and GLSL of ``parts``
        (by default all components) and the processor's ``own`` binding (which overrides them).
        ``missed``: what the shader writes into each of the target's images where the pixel's ray
        misses; given, a trivial pass writes these everywhere (shaders/missed_fill.frag.glsl says
        why not a clear) and the pass draws only inside the entry image's ``covered`` rectangle."""
        binding = self.binding(frame, parts, own)
        covered = frame.entry.covered if missed is not None else None
        if covered is not None:  # outside, the values without the shader (on llvmpipe not free)
            fill = programs.program(frame.ctx, FULLSCREEN_VERTEX_SHADER, MISSED_FILL_SHADER, {},
                                    processor=self.id)
            self.passes.append(Pass(MISSED_FILL_SHADER, {}))
            fullscreen_pass(frame.ctx, fill, target, uniforms={f"missed{i}": v for i, v in enumerate(missed)})
            target.framebuffer.scissor = covered
        program = self.program(frame, shader, binding.defines, parts)
        try:
            fullscreen_pass(frame.ctx, program, target, binding.textures, binding.uniforms,
                            samplers=binding.samplers)
        finally:
            if covered is not None:
                target.framebuffer.scissor = None
