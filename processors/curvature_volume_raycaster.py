"""CurvatureVolumeRaycaster (Cabral 2010 sec. 5.5): direct volume rendering coloured by curvature.

Conventions (docs/curvature.md explains each property):
- Opacity comes from the scalar transfer function of each sample's normalised intensity (only its
  alpha is used), corrected for the sampling rate as in the RayCaster; colour from the normalised
  curvature of the level set through the sample (the CurvatureRaycaster's measures,
  normalisations and colour maps), `undefined_color` where the curvature is undefined, optionally
  Blinn-Phong shaded. Front-to-back compositing with early termination (the RayCaster's dvr).
- One inport `volume` of the kind the derivative mode needs (samples for forward, central,
  filtered; B-spline coefficients for tricubic, tricubic_fast), as the CurvatureRaycaster.
- Linear normalisation needs kmin, kmax: a first pass (RANGE_PASS) marches the same rays and keeps
  per pixel the range of the measure over the samples that contribute (opacity > 0, curvature
  defined, before early termination), reduced on the GPU (RangeReduction); the second pass
  composites. So linear normalisation costs about twice exponential.
- Outputs: `image` RGBA32F composited over `background`; `depth` as the RayCaster's (the first
  sample with opacity > 0).
"""

from __future__ import annotations

from vgraph import (BoolProperty, CameraProperty, ColorProperty, FloatProperty, Inport,
                    Invalidation, OptionProperty, Outport, Processor, TransferFunctionProperty,
                    VGraphError)
from vgraph.gl.curvature import (COLORMAPS, CURVATURES, DERIVATIVES, NORMALIZATIONS,
                                 ColormapTexture, RangeReduction, check_volume_kind,
                                 derivative_defines, field_uniforms, measure_defines,
                                 measure_uniforms, shading_defines)
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.shaders import programs
from vgraph.gl.volume_rendering import (DEFAULT_CAMERA, RenderTargets, SkipBlocks, view_camera,
                                        TransferFunctionTexture, VolumeGeometry, block_grid_uniforms,
                                        linear_sampler, lighting_properties, occupied_blocks,
                                        radii_if_worthwhile, ray_uniforms, shading_uniforms, vec,
                                        visible_under)
from vgraph.image import Image
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

SHADER = "curvature/curvature_volume_raycaster.frag.glsl"
VOLUME_UNIT = 2  # texture unit of the volume (entry, exit, volume, ...)

# Two translucent shells, at the surface of every FunctionSelector volume (0.5) and inside it;
# only the opacity is used.
DEFAULT_TRANSFER_FUNCTION = TransferFunction(points=[
    (0.0, 1.0, 1.0, 1.0, 0.0), (0.47, 1.0, 1.0, 1.0, 0.0), (0.5, 1.0, 1.0, 1.0, 0.25),
    (0.53, 1.0, 1.0, 1.0, 0.0), (0.54, 1.0, 1.0, 1.0, 0.0), (0.56, 1.0, 1.0, 1.0, 0.6),
    (0.58, 1.0, 1.0, 1.0, 0.0), (1.0, 1.0, 1.0, 1.0, 0.0)])

RESOURCES = Invalidation.RESOURCES


class CurvatureVolumeRaycaster(Processor):
    """Direct volume rendering: opacity from the transfer function, colour from curvature."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume), Inport("entry", Image), Inport("exit", Image)]
    outports = [Outport("image", Image), Outport("depth", Image)]

    camera = CameraProperty(DEFAULT_CAMERA, doc="link it to the EntryExitPoints camera")
    transfer_function = TransferFunctionProperty(
        DEFAULT_TRANSFER_FUNCTION, doc="opacity over normalised intensity (its colours are unused)")
    derivatives = OptionProperty("tricubic", choices=list(DERIVATIVES), invalidates=RESOURCES,
                                 doc="forward, central, filtered differences (voxel samples) or "
                                     "tricubic, tricubic_fast (B-spline coefficients)")
    curvature = OptionProperty("mean", choices=list(CURVATURES), invalidates=RESOURCES,
                               doc="the measure that gives the colour")
    normalization = OptionProperty("linear", choices=list(NORMALIZATIONS), invalidates=RESOURCES,
                                   doc="linear: by the largest and smallest curvature of the "
                                       "contributing samples (an extra pass); exponential")
    attenuation = FloatProperty(1.0, min=1e-6, max=1e6,
                                doc="t of the exponential normalisation, in world units")
    colormap = OptionProperty("jet", choices=list(COLORMAPS))
    undefined_color = ColorProperty((0.5, 0.5, 0.5, 1.0),
                                    doc="colour of samples whose curvature is undefined")
    sampling_rate = FloatProperty(1.0, min=0.05, max=16.0,
                                  doc="samples per voxel of the smallest spacing")
    early_termination = FloatProperty(0.99, min=0.01, max=1.0,
                                      doc="stop a ray once its opacity reaches this")
    empty_space_skipping = BoolProperty(True, invalidates=RESOURCES,
                                        doc="skip blocks where the TF has no opacity (same image)")
    shading = OptionProperty("none", choices=["none", "blinn_phong"], invalidates=RESOURCES)
    light, light_direction, ambient, diffuse, specular, shininess = lighting_properties()
    background = ColorProperty((0.0, 0.0, 0.0, 1.0))

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._targets = RenderTargets(2)  # image (or the range in the first pass), depth
        self._reduction = RangeReduction()
        self._colormap = ColormapTexture()
        self._lut = TransferFunctionTexture()
        self._blocks = SkipBlocks()

    def shader_defines(self, range_pass: bool = False, skipping: bool | None = None) -> dict:
        """The define set of one pass (docs/curvature.md lists them)."""
        if skipping is None:
            skipping = self.empty_space_skipping
        defines = {**derivative_defines(self.derivatives),
                   **measure_defines(self.curvature, self.normalization),
                   "RANGE_PASS": range_pass, "SKIP_EMPTY_SPACE": bool(skipping),
                   "OPACITY_CORRECTION": self.sampling_rate != 1.0}
        if not range_pass:
            defines.update(shading_defines(self))
        return defines

    def visible_content(self) -> str | None:
        volume = self.inputs.get("volume")
        return visible_under(volume, self.transfer_function) if volume is not None else None

    def process(self, volume: Volume, entry: Image, exit: Image) -> dict:
        check_volume_kind(volume, self.derivatives, f"CurvatureVolumeRaycaster '{self.id}'")
        if entry.size != exit.size:
            raise VGraphError(f"entry image is {entry.size[0]}x{entry.size[1]} but exit image is "
                              f"{exit.size[0]}x{exit.size[1]}; connect both to one EntryExitPoints")
        ctx = self.gl
        image, depth = self._targets.ensure(ctx, entry.size)
        textures = {"entry_points": entry, "exit_points": exit, "volume": volume.texture(ctx),
                    "transfer_function": self._lut.update(ctx, self.transfer_function, volume),
                    "colormap": self._colormap.update(ctx, self.colormap)}
        blocks = None
        if self.empty_space_skipping:
            blocks = self._blocks.texture(ctx, volume, self.transfer_function,
                                          lambda low, high: radii_if_worthwhile(
                                              occupied_blocks(low, high, self._lut.alpha)))
        if blocks is not None:
            textures["blocks"] = blocks
        uniforms = self._uniforms(volume, entry.size)
        if self.normalization == "linear":
            self._pass(ctx, textures, uniforms, range_pass=True, skipping=blocks is not None)
            textures["curvature_range"] = self._reduction.run(
                ctx, image, measure_defines(self.curvature), self.id, measure_uniforms(volume),
                pairs=True)
        self._pass(ctx, textures, uniforms, range_pass=False, skipping=blocks is not None)
        return {"image": image, "depth": depth}

    def _pass(self, ctx, textures: dict, uniforms: dict, range_pass: bool, skipping: bool) -> None:
        program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, SHADER,
                                   self.shader_defines(range_pass, skipping), processor=self.id)
        sampler = linear_sampler(ctx)  # trilinear fetches (FD modes, the fast spline)
        sampler.use(VOLUME_UNIT)
        try:
            fullscreen_pass(ctx, program, self._targets, textures, uniforms)
        finally:
            sampler.clear(VOLUME_UNIT)

    def _uniforms(self, volume: Volume, size) -> dict:
        geometry = VolumeGeometry.of(volume)
        min_spacing = float(geometry.spacing.min())
        to_world_scale, to_world_offset = geometry.texture_to_world
        camera = self.view_camera = view_camera(self.camera, volume, size)
        rays = ray_uniforms(camera, size)
        uniforms = {"texture_to_world_scale": vec(to_world_scale),
                    "texture_to_world_offset": vec(to_world_offset),
                    "step_length": min_spacing / self.sampling_rate,
                    "opacity_exponent": 1.0 / self.sampling_rate,
                    "early_termination": self.early_termination,
                    "background": tuple(self.background),
                    "undefined_color": tuple(self.undefined_color),
                    "attenuation": self.attenuation,
                    "view_projection": camera.view_projection(size[0] / size[1]),
                    "viewport_size": (float(size[0]), float(size[1])),
                    "view_forward": vec(camera.basis()[2]),
                    "near_centre": rays["near_centre"], "near_right": rays["near_right"],
                    "near_up": rays["near_up"],
                    **field_uniforms(volume), **block_grid_uniforms(volume)}
        if self.shading != "none":
            uniforms.update(shading_uniforms(self, min_spacing))
        return uniforms
