"""The Mask and CutAway components of the ray casters (the model: vgraph.masking).

Mask: the optional inport ``mask`` (a label or binary volume on its own grid in the patient frame)
and its properties; the kept indicator as an R8 texture (made once per mask, selection and GL
context, vgraph.derived), sampled at each ray position t through one 4x4 map, the frame's
texture -> world -> the mask's texture (the identity, exactly, for a mask on the volume's own grid,
so its voxels are the volume's to the last bit). CutAway: a box or sphere in world units,
through the map texture -> world -> region coordinates. Both are GLSL of their own
(raycasting/mask.glsl, raycasting/cutaway.glsl), combined into a sample's weight by
raycasting/sample_weight.glsl; with no mask connected and no region, the defines MASK and
CUTAWAY_* are off and the weight is the literal 1.0: images are the same bit for bit.

A processor with these components calls ``use(mask)`` (Mask) before drawing a frame; either
refuses what it cannot draw (``check_drawable``) naming the processor and the port or property.
"""

from __future__ import annotations

import moderngl
import numpy as np

from vgraph import derived
from vgraph.errors import VGraphError
from vgraph.gl.raycasting.geometry import VolumeGeometry
from vgraph.gl.raycasting.raycaster_base import Binding, Component, Frame
from vgraph.masking import (BOUNDARIES, MODES, SHAPES, CutAwayRegion, LabelListProperty, MaskSelection,
                            check_overlap, kept_indicator, parse_labels, world_to_mask_texture)
from vgraph.ports import Inport
from vgraph.properties import FloatProperty, OptionProperty, VectorProperty
from vgraph.volume import Volume

INDICATOR_TEXTURE = "mask indicator texture"  # kind of derived data (vgraph.derived)


def texture_to_world(frame: Frame) -> np.ndarray:
    """4x4 float64: the frame volume's texture coordinates -> world (patient) points, through the
    frame the volume is drawn in (vgraph.box_frame)."""
    scale, offset = VolumeGeometry.of(frame.volume).texture_to_world
    corners = np.vstack([np.zeros(3), np.eye(3)]) * scale + offset
    world = frame.box_frame.world_points(corners)
    matrix = np.eye(4)
    matrix[:3, :3] = (world[1:] - world[0]).T
    matrix[:3, 3] = world[0]
    return matrix


def _same_grid(a: Volume, b: Volume) -> bool:
    return (tuple(a.dims) == tuple(b.dims) and np.array_equal(a.spacing, b.spacing)
            and np.array_equal(a.origin, b.origin) and np.array_equal(a.direction, b.direction))


class Mask(Component):
    """The ``mask`` inport and its selection (vgraph.masking)."""

    inports = (Inport("mask", Volume, "label or binary volume on its own grid: samples outside the "
                                      "kept labels are skipped", optional=True),)
    glsl = ("raycasting/mask.glsl",)

    def declare(self):
        return {"mask_labels": LabelListProperty("", doc="labels of the mask kept (or hidden), e.g. '2' or "
                                                      "'1, 3'; empty: every nonzero voxel"),
                "mask_mode": OptionProperty("keep", choices=list(MODES),
                                            doc="keep: draw only where the mask holds these labels; "
                                                "hide: cut them away"),
                "mask_boundary": OptionProperty("hard", choices=list(BOUNDARIES),
                                                doc="hard: the nearest mask voxel decides; smooth: the "
                                                    "indicator blurred and interpolated linearly"),
                "mask_smoothing": FloatProperty(1.0, min=0.0, max=8.0,
                                                doc="smooth boundary: Gaussian width in mask voxels")}

    def start(self) -> None:
        self.volume: Volume | None = None   # the mask of the frame being drawn
        self.original: Volume | None = None  # the data volume as it arrived (for the overlap test)

    @property
    def consumer(self) -> str:
        source = f" ({self.volume.source})" if self.volume is not None and self.volume.source else ""
        return f"{self.processor.id}.mask{source}"

    def selection(self) -> MaskSelection:
        processor = self.processor
        return MaskSelection(parse_labels(processor.mask_labels, f"{processor.id}.mask_labels"),
                             processor.mask_mode, processor.mask_boundary, processor.mask_smoothing)

    def use(self, mask: Volume | None, volume: Volume) -> None:
        """The mask of the next frame of ``volume`` (None: none), checked."""
        self.volume, self.original = mask, volume
        if mask is not None:
            self.selection()  # a malformed label list is refused before drawing
            check_overlap(mask, volume, self.consumer)

    @property
    def active(self) -> bool:
        return self.volume is not None

    def bind(self, frame: Frame) -> Binding:
        if self.volume is None:
            return Binding(defines={"MASK": False, "MASK_HARD": False})
        mask, selection = self.volume, self.selection()
        texture = derived.value(mask, INDICATOR_TEXTURE, lambda: self._texture(frame.ctx, selection),
                                params=selection, ctx=frame.ctx)
        same = frame.box_frame.is_identity and _same_grid(frame.volume, mask) and _same_grid(self.original, mask)
        matrix = np.eye(4) if same else world_to_mask_texture(mask) @ texture_to_world(frame)
        hard = selection.boundary == "hard"
        uniforms = {"texture_to_mask": matrix, "mask_outside": selection.outside()}
        if hard:
            uniforms["mask_dims"] = tuple(int(d) for d in mask.dims)
        return Binding(defines={"MASK": True, "MASK_HARD": hard}, textures={"mask": texture}, uniforms=uniforms)

    def _texture(self, ctx: moderngl.Context, selection: MaskSelection) -> moderngl.Texture:
        mask = self.volume
        limit = ctx.info["GL_MAX_3D_TEXTURE_SIZE"]
        if max(mask.dims) > limit:
            raise VGraphError(f"{self.consumer}: {' x '.join(map(str, mask.dims))} voxels exceed this GL's "
                              f"3D texture limit of {limit} per axis; resample the mask")
        indicator = kept_indicator(mask, selection, self.consumer)
        texture = ctx.texture3d(mask.dims, 1, np.ascontiguousarray(indicator).tobytes(), dtype="f1", alignment=1)
        linear = moderngl.NEAREST if selection.boundary == "hard" else moderngl.LINEAR
        texture.filter = (linear, linear)
        texture.repeat_x = texture.repeat_y = texture.repeat_z = False
        return texture


class CutAway(Component):
    """A box or sphere region subtracted from the rendering (vgraph.masking)."""

    glsl = ("raycasting/cutaway.glsl",)

    def declare(self):
        return {"cutaway": OptionProperty("none", choices=list(SHAPES),
                                          doc="a region subtracted from the rendering: none, box or sphere"),
                "cutaway_center": VectorProperty((0.0, 0.0, 0.0), doc="the region's centre, world units"),
                "cutaway_size": VectorProperty((1.0, 1.0, 1.0), min=0.0,
                                               doc="box: edge lengths; sphere: diameters (world units, "
                                                   "on the world axes)")}

    def region(self) -> CutAwayRegion:
        processor = self.processor
        return CutAwayRegion(processor.cutaway, tuple(processor.cutaway_center),
                             tuple(processor.cutaway_size)).checked(f"{processor.id}.cutaway_size")

    @property
    def active(self) -> bool:
        return self.processor.cutaway != "none"

    def bind(self, frame: Frame) -> Binding:
        region = self.region()
        defines = {"CUTAWAY_BOX": region.shape == "box", "CUTAWAY_SPHERE": region.shape == "sphere"}
        if region.shape == "none":
            return Binding(defines=defines)
        return Binding(defines=defines,
                       uniforms={"texture_to_region": region.world_to_region() @ texture_to_world(frame)})


def check_drawable(processor, parts, why_not: str | None) -> None:
    """Refuse a mask or cut-away on a frame that cannot draw them (``why_not``: the reason, e.g.
    'iso', or None when it can), naming the processor and the port or property."""
    if why_not is None:
        return
    if parts[Mask].active:
        raise VGraphError(f"{processor.id}.mask: {why_not}; disconnect the mask")
    if parts[CutAway].active:
        raise VGraphError(f"{processor.id}.cutaway: {why_not}; set it to none")
