"""LabelRayCaster: ray casting of a label volume (integer labels, e.g. a segmentation) coloured by a
label table, as Voreen's segmentation ray caster and napari's labels layer do.

Conventions (docs/guide/exploring.md has pictures):
- Labels are never interpolated as numbers. Each sample takes its label by the majority of
  interpolation weights (vgraph.labels): the 8 voxels around the sample vote with their trilinear
  weights, the label (or the background: every label that is not shown) with the largest sum wins.
  Boundaries are smooth surfaces, half-way between voxel centres where two labels touch, and no
  colour bleeds between labels: a sample has the colour of exactly one label.
- The labels are read from their own texture: exact unsigned integer codes (R16UI, or R32UI for
  more than 65536 distinct labels; vgraph.labels.label_codes), uploaded once per volume and GL
  context and kept with the volume. The volume's value range plays no part. Float volumes are
  accepted only when every value is a whole number; anything else is refused, naming the processor.
- ``label_table``: colour, opacity and visibility per label (vgraph.labels.LabelTable); labels it
  does not list get palette colours (or are hidden, ``unlisted = "hidden"``).
- ``compositing``: composite (each shown label at its opacity per sample at rate 1, corrected for
  the step, front to back with early termination) or first_hit (the first shown label's colour,
  opaque: a surface view; the hit refined by halvings of the step to the boundary). ``shading``
  blinn_phong lights samples with a gradient of the weight sums as normal, which the rule has
  already (no extra fetch): next to the background that of all shown labels together (their outer
  surface; no seam where two labels touch), elsewhere the winning label's own boundary (label
  interiors stay unshaded).
- Empty-space skipping: blocks whose voxels (with the rule's one-voxel margin) hold no shown label
  are jumped over and bound the rays (components.EmptySpace); the picture does not change.
- Samples as the RayCaster's: every min(spacing) / sampling_rate world units from the entry point
  (raycasting/ray.glsl), so clipping planes in EntryExitPoints apply here too.
  ``vgraph.numerics.reference_labels`` is the CPU reference of the picture.
- The optional inport ``mask`` and the cut-away region (vgraph.masking) weigh each sample: its
  label's opacity (composite) or, below 1/2, no hit (first_hit; after such a sample the hit is the
  sample itself, not refined into the removed part).
- ``depth`` (on demand, drawn only when something reads it: the picking of vgraph.picking): the
  RayCaster's depth output convention (raycasting/depth_output.glsl) at the first sample whose
  label is shown (first_hit: at the refined hit), a = 0 where no shown label is met.
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from vgraph import Inport, OptionProperty, Outport, VGraphError, derived
from vgraph.gl.raycasting.components import Background, CameraRays, EmptySpace, EntryExit, FrontToBack, Sampling
from vgraph.gl.raycasting.light import Light
from vgraph.gl.raycasting.mask import CutAway, Mask
from vgraph.gl.raycasting.raycaster_base import Binding, Frame, RaycasterBase
from vgraph.gl.raycasting.empty_space import radii_if_worthwhile, window_reduced
from vgraph.gl.raycasting.geometry import vec
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.raycasting.textures import needs_bricks
from vgraph.image import Image
from vgraph.labels import LabelCodes, LabelTable, label_codes
from vgraph.properties import LabelTableProperty
from vgraph.shown_content import labelled_voxels
from vgraph.volume import Volume

SHADER = "labels/label_raycaster.frag.glsl"
COMPOSITING = ("composite", "first_hit")
LABEL_ROW = 256  # codes per row of the colour table texture (shaders/labels/majority.glsl)
CODES, CODES_TEXTURE = "label codes", "label codes texture"  # kinds of derived data (vgraph.derived)


def skip_values(raycaster: "LabelRayCaster", frame):
    """Empty-space skipping (components.EmptySpace): blocks whose voxels, with the one-voxel
    margin the majority rule reads, hold no shown label are empty. Ray bounds follow from them
    ("opacity": empty blocks contribute nothing), so the image is the same, only cheaper."""
    codes = raycaster.frame_codes
    shown = raycaster.label_table.colors(codes.values)[:, 3] > 0.0  # only this matters, not the colours
    return ("opacity", shown.tobytes()), lambda low, high: radii_if_worthwhile(shown_blocks(codes, shown))


class LabelRayCaster(RaycasterBase):
    """Ray casting of integer labels: a colour and opacity per label, smooth boundaries, no bleeding.

    Each sample's label is the majority of its 8 voxels' interpolation weights (module docstring)."""

    category = "Volume rendering"
    inports = [Inport("labels", Volume)]
    outports = [Outport("image", Image), Outport("depth", Image, on_demand=True)]
    components = (EntryExit(), CameraRays(), Sampling(), FrontToBack(), Light(), EmptySpace(skip=skip_values),
                  Background(), Mask(), CutAway())

    label_table = LabelTableProperty(LabelTable.default(),
                                     doc="per label value: name, colour, opacity, visible; unlisted "
                                         "labels: palette colours or hidden")
    compositing = OptionProperty("composite", choices=list(COMPOSITING),
                                 doc="composite: labels at their opacities, front to back; first_hit: "
                                     "the first shown label's colour, opaque")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._targets = {True: RenderTargets(2), False: RenderTargets(1)}  # by: depth output wanted
        self._colors = ColorTable()
        self.frame_codes: LabelCodes | None = None  # of the frame being drawn (skip_values reads them)

    def process(self, labels: Volume, entry: Image, exit: Image, mask: Volume | None = None) -> dict:
        consumer = self._checked(labels)
        self.parts[Mask].use(mask, labels)
        frame = self.frame(labels, entry, exit)
        with_depth = self.wants("depth")
        targets = self._targets[with_depth]
        self._targets[not with_depth].release()  # a scene keeps the images of one kind only
        outputs = dict(zip(("image", "depth"), targets.ensure(frame.ctx, entry.size)))
        own = self._label_binding(frame, labels, consumer).merge(Binding({"DEPTH_OUTPUT": with_depth}))
        self.draw(frame, SHADER, targets, own=own)
        return outputs

    def _checked(self, labels: Volume) -> str:
        """``labels`` as the error messages name it, once refused if it cannot be drawn. The
        scheduler's ProcessorError names the processor too; the file says which data."""
        consumer = f"{self.id}.labels" + (f" ({labels.source})" if labels.source else "")
        labels.require_samples(consumer)
        if needs_bricks(labels, self.gl):  # a store within its memory budget is read whole
            raise VGraphError(f"{consumer}: label volumes are drawn from one texture; this one "
                              f"({' x '.join(map(str, labels.dims))} voxels) exceeds the GL's 3D "
                              f"texture size or its memory budget (VolumeSource.memory_budget)")
        return consumer

    def _label_binding(self, frame: Frame, labels: Volume, consumer: str) -> Binding:
        """The LabelRayCaster's own part of the pass: the compositing mode, the label codes and
        the label table resolved per code (majority.glsl), the spacing for shading
        (label_shading.glsl). The frame's codes are kept for skip_values."""
        codes, texture = label_textures(labels, frame.ctx, consumer)
        self.frame_codes = codes
        colors = self._colors.update(frame.ctx, self.label_table, codes)
        return Binding(defines={f"COMPOSITING_{self.compositing.upper()}": True},
                       textures={"labels": texture, "label_colors": colors},
                       uniforms={"volume_dims": tuple(int(d) for d in labels.dims),
                                 "voxel_spacing": vec(frame.geometry.spacing)})

    def visible_content(self) -> str | None:
        """The share of voxels holding shown labels (for the scheduler's empty-image warning)."""
        volume = self.inputs.get("labels")
        codes = derived.peek(volume, CODES) if volume is not None else None
        if codes is None:  # not drawn (refused, or never run)
            return None
        share = (self.label_table.colors(codes.values)[:, 3] > 0.0)[codes.codes].mean()
        return f"{share:.0%} of the voxels hold shown labels" if share > 0 else None

    def shown_content(self) -> list:
        """The voxels whose label its table shows (vgraph.blank_causes)."""
        volume = self.inputs.get("labels")
        return [labelled_voxels("labels", volume, self.label_table)] if volume is not None else []


def label_textures(volume: Volume, ctx: moderngl.Context, consumer: str) -> tuple[LabelCodes, moderngl.Texture]:
    """The volume's label codes and their integer 3D texture on ``ctx``, made once and kept in the
    cache for derived data (vgraph.derived): another frame, table or ray caster of the same volume
    reuses them; they go when the volume (the texture: or the context) goes."""
    codes = derived.value(volume, CODES, lambda: label_codes(volume.data, consumer))
    return codes, derived.value(volume, CODES_TEXTURE, lambda: _codes_texture(volume, codes, ctx, consumer),
                                ctx=ctx)


def _codes_texture(volume: Volume, codes: LabelCodes, ctx: moderngl.Context, consumer: str) -> moderngl.Texture:
    limit = ctx.info["GL_MAX_3D_TEXTURE_SIZE"]
    if max(volume.dims) > limit:
        raise VGraphError(f"{consumer}: {' x '.join(map(str, volume.dims))} voxels exceed this GL's "
                          f"3D texture limit of {limit} per axis")
    dtype = "u2" if codes.codes.dtype == np.uint16 else "u4"
    texture = ctx.texture3d(volume.dims, 1, np.ascontiguousarray(codes.codes).tobytes(), dtype=dtype,
                            alignment=1)
    # Integer textures are incomplete (read as 0) with linear filtering; texelFetch reads them.
    texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
    texture.repeat_x = texture.repeat_y = texture.repeat_z = False
    return texture


def shown_blocks(codes: LabelCodes, shown_codes: np.ndarray) -> np.ndarray:
    """Per empty-space block [bz, by, bx]: whether a voxel of it holds a shown code (``shown_codes``
    per code); block b covers voxels [b * BLOCK - 1, (b + 1) * BLOCK + 1] on each axis
    (empty_space.window_reduced, as the block ranges)."""
    shown = shown_codes[codes.codes]
    for axis in range(3):
        shown = window_reduced(shown, axis, np.logical_or)
    return shown


class ColorTable:
    """The label table resolved per code (LabelTable.colors) as an RGBA32F texture of LABEL_ROW codes
    a row, rewritten only when the table or the codes change."""

    def __init__(self):
        self.texture = None
        self.key = None

    def update(self, ctx: moderngl.Context, table: LabelTable, codes: LabelCodes) -> moderngl.Texture:
        key = (table, codes, ctx)
        if self.texture is not None and key == self.key and self.texture.ctx is ctx:
            return self.texture
        rows = max(1, math.ceil(codes.values.size / LABEL_ROW))
        if rows > ctx.info["GL_MAX_TEXTURE_SIZE"]:
            raise VGraphError(f"{codes.values.size} distinct labels exceed this GL's colour table of "
                              f"{LABEL_ROW * ctx.info['GL_MAX_TEXTURE_SIZE']} labels")
        rgba = np.zeros((rows * LABEL_ROW, 4), dtype=np.float32)
        rgba[:codes.values.size] = table.colors(codes.values)
        if self.texture is None or self.texture.ctx is not ctx or self.texture.size != (LABEL_ROW, rows):
            self.texture = ctx.texture((LABEL_ROW, rows), 4, dtype="f4")
            self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.texture.write(rgba.tobytes())
        self.key = key
        return self.texture
