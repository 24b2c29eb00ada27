"""SliceViewer: a plane through a volume as an image (the views of a multi-planar layout, MPR).

Conventions (vgraph.slicing has the geometry's long form; docs/guide/exploring.md shows it in use):
- Orientation (world axes RAS, the patient's: x right, y front, z up): axial = constant z,
  coronal = constant y, sagittal = constant x. ``display`` radiological (default: the patient's
  right on the image's left, as DICOM viewers show a slice): axial seen from below (image right =
  -x, up = +y), coronal from the front (right = -x, up = +z); neurological (the patient's right on
  the image's right): the same images mirrored left to right (axial from above, coronal from
  behind). Sagittal in both: from the left (right = -y, up = +z). ``custom``: the plane with
  ``normal`` (pointing towards the viewer; image up = world z projected onto the plane, or world y
  when the normal is along z), whatever the display.
- The plane passes through ``cursor``, a world point (None = the centre of the volume). Linking
  the cursors of several SliceViewers makes them one shared cursor: in the GUI a click in one
  slice moves the others (vgraph.live.slice_clicks).
- Everything is in world units through the volume's affine (spacing, direction, origin): the image
  fits the box of the voxels' cells (index box [-1/2, n - 1/2], turned as the volume is) projected
  onto the plane, square pixels, aspect kept; ``zoom`` magnifies about the cursor. A volume whose
  index axes are tilted against the world is sliced in the world: its axial slice shows the tilted
  anatomy. An axis-aligned slice of n voxels drawn at n pixels puts every pixel centre on a voxel
  centre, so a DICOM axial slice (ImageOrientationPatient [1, 0, 0, 0, 1, 0]) drawn at its own
  size is pydicom's pixel_array, row 0 at the top and column 0 at the left (radiological).
- The plane reaches the shader in voxel indices: its centre and edge vectors mapped through the
  inverse affine in float64 on the CPU (vgraph.slicing.GridBox), so a pixel costs one
  multiply-add per axis and an axis-aligned volume gets exactly the numbers it got before.
- Thick slab (``slab_thickness`` > 0, world units): maximum intensity projection over the slab
  centred on the plane, each pixel the largest intensity of samples along the normal one voxel
  step apart (vgraph.slicing.voxel_step; for an axis-aligned slice the spacing along its axis),
  the plane's and as many as fit within half the thickness on either side (a thickness of 4
  voxel steps: 5 samples; under 2 steps: the plane alone), samples outside the cells skipped;
  the mapping applies to that maximum. A pixel is inside the image where its plane point is.
- ``pan``: a world vector whose part in the plane moves the image's centre; linked between the
  viewers (as networks/mpr_mri_head.json links it and ``zoom``) it pans them together.
- interpolation: nearest (the voxel whose cell holds the point), linear (trilinear), cubic (the
  cubic B-spline through the voxels, Cabral 2010 sec. 3.1-3.2: the volume's normalised
  intensities are prefiltered once per volume on the CPU, mirror boundary, and evaluated by the
  tricubic library's direct 64-fetch sum: float32 weights on any GPU. The 8-fetch fast form was
  3x faster on llvmpipe, 40 against 135 ms for a 384^2 slice, but inherits the texture unit's
  filter weights, 8-bit on many GPUs).
- mapping: ``window`` gives grey = (value - (centre - width / 2)) / width clamped to [0, 1], opaque,
  with ``window`` = (centre, width) in the volume's DATA values (as DICOM's WindowCenter and
  WindowWidth; None = the whole value range); ``tf`` gives the transfer function's RGBA (not
  premultiplied, as every vgraph Image).
- Pixels outside the volume's cells are transparent black (0, 0, 0, 0); a plane that misses the
  volume gives an empty image, not an error.
- Output: an RGBA32F image at the render size (the Canvas's). ``last_plane`` is the plane of the
  last image (vgraph.slicing.SlicePlane); ``pixel_to_world`` maps pixels of that image to world
  points. The fragment shader (shaders/slice/) is compiled once per define set: only the chosen
  interpolation and mapping.
"""

from __future__ import annotations

import weakref

import numpy as np

from vgraph import (BoolProperty, ColorProperty, FloatProperty, Inport, OptionProperty, Outport,
                    Processor, TransferFunctionProperty, VectorProperty, VGraphError)
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.raycasting.textures import TransferFunctionTexture, linear_sampler
from vgraph.gl.shaders import programs
from vgraph.image import Image
from vgraph.numerics.bspline import prefilter
from vgraph.shown_content import every_voxel, voxels_under
from vgraph.slicing import DISPLAYS, ORIENTATIONS, SlicePlane, checked_plane, index_vectors, voxel_step
from vgraph.transfer_function import PRESETS
from vgraph.volume import Volume

SHADER = "slice/slice.frag.glsl"
INTERPOLATIONS = ("nearest", "linear", "cubic")
MAPPINGS = ("window", "tf")


class SliceViewer(Processor):
    """A plane through the volume as an image: axial, coronal, sagittal or any normal."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume)]
    outports = [Outport("image", Image)]
    renders_at_size = True

    orientation = OptionProperty("axial", choices=[*ORIENTATIONS, "custom"],
                                 doc="axial = constant z, coronal = constant y, sagittal = constant "
                                     "x (world axes RAS); custom: the plane with the given normal")
    display = OptionProperty("radiological", choices=list(DISPLAYS),
                             doc="radiological: the patient's right on the image's left (axial seen "
                                 "from below, coronal from the front); neurological: the patient's "
                                 "right on the image's right (mirrored)")
    cursor = VectorProperty(None, size=3, optional=True,
                            doc="world point the plane passes through (auto: the volume's centre); "
                                "link it between viewers for a shared cursor")
    normal = VectorProperty((0.0, 0.0, 1.0), size=3,
                            doc="custom orientation: the plane's normal, towards the viewer")
    interpolation = OptionProperty("linear", choices=list(INTERPOLATIONS),
                                   doc="nearest voxel, trilinear, or cubic B-spline")
    mapping = OptionProperty("window", choices=list(MAPPINGS),
                             doc="window: grey values by window; tf: the transfer function's colours")
    window = VectorProperty(None, size=2, optional=True,
                            doc="(centre, width) in the volume's data values (auto: the whole "
                                "value range)")
    transfer_function = TransferFunctionProperty(PRESETS["grayscale"],
                                                 doc="colours and opacities for mapping = tf")
    zoom = FloatProperty(1.0, min=0.01, max=1000.0,
                         doc="1 fits the volume; larger magnifies about the cursor")
    pan = VectorProperty((0.0, 0.0, 0.0), size=3,
                         doc="world vector moving the image's centre (its part in the plane); "
                             "link it between viewers for a linked pan")
    slab_thickness = FloatProperty(0.0, min=0.0, max=1e6,
                                   doc="thick-slab MIP: the largest value over this thickness "
                                       "(world units) centred on the plane; 0: the plane alone")
    crosshair = BoolProperty(False, doc="draw the cursor's row and column of pixels into the image "
                                        "(for scripts and exports; the GUI draws the slices' "
                                        "crosshairs on screen)")
    crosshair_color = ColorProperty((1.0, 0.8, 0.1, 1.0), doc="colour of the crosshair")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self.last_plane: SlicePlane | None = None
        self._target = RenderTargets(1)
        self._lut = TransferFunctionTexture()
        self._spline: tuple[weakref.ref, Volume] | None = None  # (volume, its B-spline coefficients)

    # --- checks ---------------------------------------------------------------------------------
    def check(self) -> None:
        if self.orientation == "custom" and not np.linalg.norm(self.normal) > 0.0:
            raise VGraphError(f"{self.id}.normal: the normal {tuple(self.normal)} has no direction; "
                              f"give a non-zero (x, y, z) for the custom orientation")
        if self.window is not None and not self.window[1] > 0.0:
            raise VGraphError(f"{self.id}.window: the width (second number) must be positive, got "
                              f"{self.window[1]:g}; the window is (centre, width) in data values")

    # --- geometry -------------------------------------------------------------------------------
    def plane(self, volume: Volume, size: tuple[int, int]) -> SlicePlane:
        """Where an image of ``size`` (width, height) of ``volume`` lies in the world."""
        return checked_plane(f"{self.id}", orientation=self.orientation, normal=self.normal,
                             cursor=self.cursor, zoom=self.zoom, origin=volume.origin,
                             spacing=volume.spacing, dims=volume.dims, size=tuple(size),
                             direction=volume.direction, display=self.display, pan=self.pan)

    def pixel_to_world(self, column, row) -> np.ndarray:
        """World points of pixel centres (column, row) of the last image, row 0 at the top;
        fractional pixels allowed (SlicePlane.pixel_to_world)."""
        if self.last_plane is None:
            raise VGraphError(f"{self.id}: no slice drawn yet, so no pixel has a world position")
        return self.last_plane.pixel_to_world(column, row, tuple(self.render_size))

    def shown_content(self) -> list:
        """The voxels its mapping shows: every one through the window, or those the transfer
        function gives opacity; ``last_plane`` says where the slice lies (vgraph.blank_causes)."""
        volume = self.inputs.get("volume")
        if volume is None:
            return []
        if self.mapping == "tf":
            return [voxels_under("volume", volume, self.transfer_function)]
        return [every_voxel("volume", volume)]

    # --- evaluation -----------------------------------------------------------------------------
    def process(self, volume: Volume) -> Image:
        volume.require_samples(f"SliceViewer '{self.id}'")
        self.check()
        size = tuple(int(v) for v in self.render_size)
        plane = self.plane(volume, size)
        ctx = self.gl
        sampled = self._coefficients(volume) if self.interpolation == "cubic" else volume
        defines = {f"INTERPOLATION_{self.interpolation.upper()}": True,
                   f"MAPPING_{self.mapping.upper()}": True, "CROSSHAIR": self.crosshair,
                   "SLAB": self.slab_steps(volume, plane) > 0}
        program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, SHADER, defines, processor=self.id)
        textures = {"volume": sampled.texture(ctx)}
        if self.mapping == "tf":
            textures["transfer_function"] = self._lut.update(ctx, self.transfer_function, volume)
        (target,) = self._target.ensure(ctx, size)
        fullscreen_pass(ctx, program, target, textures=textures,
                        uniforms=self._uniforms(volume, sampled, plane, size),
                        samplers={"volume": linear_sampler(ctx)} if self.interpolation == "linear" else None,
                        optional={"volume_dims", "cursor_pixel", "crosshair_color", "voxel_normal",
                                  "slab_half_steps"})
        self.last_plane = plane
        return target

    def _uniforms(self, volume: Volume, sampled: Volume, plane: SlicePlane, size) -> dict:
        scale, offset = sampled.texture_scale_offset()
        low, width = self._window_normalised(volume)
        uniforms = {
            "image_size": _vec(size),
            "voxel_centre": _vec(plane.box.indices(plane.centre)),  # world -> voxel: the inverse affine
            "voxel_right": _vec(index_vectors(plane.right, volume.spacing, volume.direction)),
            "voxel_up": _vec(index_vectors(plane.up, volume.spacing, volume.direction)),
            "volume_size": _vec(volume.dims),
            "volume_dims": tuple(int(n) for n in volume.dims),
            "intensity_scale": float(scale), "intensity_offset": float(offset),
            "window_low": low, "window_width": width}
        half_steps = self.slab_steps(volume, plane)
        if half_steps:
            step = voxel_step(plane.normal, volume.spacing, volume.direction)
            uniforms["voxel_normal"] = _vec(index_vectors(np.asarray(plane.normal) * step,
                                                          volume.spacing, volume.direction))
            uniforms["slab_half_steps"] = half_steps
        if self.crosshair:
            point = plane.centre if self.cursor is None else self.cursor
            u, v = plane.uv_of(point)
            uniforms["cursor_pixel"] = _vec((u * size[0], v * size[1]))
            uniforms["crosshair_color"] = tuple(self.crosshair_color)
        return uniforms

    def slab_steps(self, volume: Volume, plane: SlicePlane) -> int:
        """Samples on either side of the plane in a thick slab: one voxel step apart (voxel_step),
        as many as fit in half the thickness (0: no slab)."""
        if not self.slab_thickness > 0.0:
            return 0
        step = voxel_step(plane.normal, volume.spacing, volume.direction)
        return int(np.floor(self.slab_thickness / 2.0 / step + 1e-9))

    def _window_normalised(self, volume: Volume) -> tuple[float, float]:
        """The window's lower end and width as normalised intensities of ``volume``."""
        lo, hi = volume.value_range
        centre, width = self.window if self.window is not None else ((lo + hi) / 2.0, hi - lo)
        return float((centre - width / 2.0 - lo) / (hi - lo)), float(width / (hi - lo))

    def _coefficients(self, volume: Volume) -> Volume:
        """The volume's cubic B-spline coefficients of its normalised intensities (float32, so
        one texture holds them for any data type), computed once per volume."""
        if self._spline is not None and self._spline[0]() is volume:
            return self._spline[1]
        data = volume.normalized(volume.data).astype(np.float32)
        if volume.nonfinite_count:  # a NaN would smear along whole lines of the recursive filter
            data = np.nan_to_num(data, nan=0.0, posinf=1.0, neginf=0.0)
        coefficients = volume.with_data(prefilter(data), declared_range=(0.0, 1.0),
                                        is_spline_coefficients=True)
        self._spline = (weakref.ref(volume), coefficients)
        return coefficients


def _vec(values) -> tuple[float, ...]:
    return tuple(float(v) for v in values)
