"""RayCaster (Inácio 2009 ch. 4.2-4.3): GPU ray casting between the EntryExitPoints images.

Conventions (docs/rendering.md explains each property with pictures):
- The optical model is the CPU reference's (vgraph.numerics.reference_raycast): samples every
  min(spacing) / sampling_rate world units from the entry point, trilinear reconstruction, the TF's
  4096-entry LUT with linear filtering, opacity correction 1 - (1 - a)^(1 / sampling_rate),
  front-to-back compositing with early termination, MIP classified once, Blinn-Phong shading with a
  headlight and central differences. The GL image matches the reference within the tolerances in
  docs/rendering.md.
- The fragment shader is composed from shaders/raycasting/*.glsl with defines chosen from the
  properties (shader_defines()); options that change the define set invalidate RESOURCES, the
  rest are uniforms. Two defines also follow values: OPACITY_CORRECTION (sampling_rate != 1) and
  SKIP_EMPTY_SPACE (off when under MIN_EMPTY_FRACTION of the blocks are empty for this TF), so
  process() looks the program up in the cache each time: a define set is compiled once.
- Outputs: `image` RGBA (composited over `background`); `depth` RGBA32F with r = window-space depth
  in [0, 1] of the depth sample (GL depth-buffer convention, 1 where there is none), g = its
  distance in world units from the ray's start on the near plane, b = the number of samples the ray
  evaluated (a debug counter; skipped empty space is not counted), a = 1 where there is a depth
  sample. Which sample gives the depth depends on the compositing mode (the shader parts say).
- The camera must equal the EntryExitPoints camera (link them): it gives depth and view direction.
"""

from __future__ import annotations

from vgraph import (BoolProperty, CameraProperty, ColorProperty, FloatProperty, Inport,
                    Invalidation, OptionProperty, Outport, Processor, TransferFunctionProperty,
                    VGraphError)
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.shaders import programs
from vgraph.gl.volume_rendering import (DEFAULT_CAMERA, RenderTargets, SkipBlocks,
                                        TransferFunctionTexture, VolumeGeometry, block_grid_uniforms,
                                        lighting_properties, linear_sampler, occupied_blocks,
                                        radii_if_worthwhile, ray_uniforms, shading_uniforms, vec,
                                        crossed_by, view_camera, visible_under)
from vgraph.image import Image
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

FRAGMENT_SHADER = "raycasting/raycaster.frag.glsl"
COMPOSITING = ("dvr", "mip", "iso", "first_hit", "xray")
SHADED_MODES = ("dvr", "iso")
SKIPPING = {"dvr": "opacity", "first_hit": "opacity", "iso": "level", "mip": "maximum"}
GRADIENTS = ("none", "forward", "backward", "central", "sobel")
# Raw texture differences -> normalised intensity per world unit: divide by this many spacings.
GRADIENT_SPACINGS = {"forward": 1.0, "backward": 1.0, "central": 2.0, "sobel": 32.0}
VOLUME_UNIT = 2  # texture unit of the volume (entry, exit, volume, ...: see process())

DEFAULT_TRANSFER_FUNCTION = TransferFunction(points=[
    (0.0, 0.0, 0.0, 0.0, 0.0), (0.45, 0.85, 0.55, 0.3, 0.0), (0.55, 0.95, 0.8, 0.6, 0.4),
    (1.0, 1.0, 1.0, 1.0, 0.8)])

RESOURCES = Invalidation.RESOURCES


class RayCaster(Processor):
    """Ray casting of a volume between entry and exit points: DVR, MIP, iso-surface and more."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume), Inport("entry", Image), Inport("exit", Image)]
    outports = [Outport("image", Image), Outport("depth", Image)]

    camera = CameraProperty(DEFAULT_CAMERA, doc="link it to the EntryExitPoints camera")
    transfer_function = TransferFunctionProperty(
        DEFAULT_TRANSFER_FUNCTION, doc="RGBA over normalised intensity, data values or percentiles "
                                       "(a preset name or TF file also works); alpha per sample at rate 1")
    sampling_rate = FloatProperty(1.0, min=0.05, max=16.0,
                                  doc="samples per voxel of the smallest spacing (world-space step)")
    compositing = OptionProperty("dvr", choices=list(COMPOSITING), invalidates=RESOURCES,
                                 doc="dvr, mip, iso (surface at iso_level), first_hit (positions), "
                                     "xray (average intensity)")
    iso_level = FloatProperty(0.5, min=0.0, max=1.0, doc="normalised intensity of the iso-surface")
    interpolation = OptionProperty("trilinear", choices=["nearest", "trilinear"],
                                   invalidates=RESOURCES)
    gradient = OptionProperty("central", choices=list(GRADIENTS), invalidates=RESOURCES,
                              doc="finite differences for shading normals")
    shading = OptionProperty("none", choices=["none", "blinn_phong"], invalidates=RESOURCES,
                             doc="lighting of dvr and iso samples (mip, xray, first_hit: none)")
    light, light_direction, ambient, diffuse, specular, shininess = lighting_properties()
    early_termination = FloatProperty(0.99, min=0.01, max=1.0,
                                      doc="dvr stops a ray once its opacity reaches this")
    empty_space_skipping = BoolProperty(True, invalidates=RESOURCES,
                                        doc="skip blocks that cannot contribute (same image, faster)")
    background = ColorProperty((0.0, 0.0, 0.0, 1.0))

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._targets = RenderTargets(2)
        self._lut = TransferFunctionTexture()
        self._blocks = SkipBlocks()

    # --- shader ---------------------------------------------------------------------------------
    def shader_defines(self, skipping: bool | None = None) -> dict[str, bool]:
        """The define set of the current properties (docs/rendering.md lists them). ``skipping``
        says whether empty-space skipping pays for this volume and TF (process() decides; by
        default it follows the property and the mode)."""
        mode = self.compositing
        if skipping is None:
            skipping = self.empty_space_skipping and mode in SKIPPING
        defines = {f"COMPOSITING_{mode.upper()}": True,
                   "INTERPOLATION_NEAREST": self.interpolation == "nearest",
                   "OPACITY_CORRECTION": mode == "dvr" and self.sampling_rate != 1.0,
                   "SKIP_EMPTY_SPACE": skipping}
        if self.shading != "none" and mode in SHADED_MODES:
            defines.update({"SHADING_BLINN_PHONG": True, f"GRADIENT_{self.gradient.upper()}": True,
                            "LIGHT_HEADLIGHT": self.light == "headlight"})
        return defines

    def visible_content(self) -> str | None:
        volume = self.inputs.get("volume")
        if volume is None:
            return None
        if self.compositing == "iso":
            return crossed_by(volume, self.iso_level)
        return visible_under(volume, self.transfer_function)

    def build_resources(self) -> None:
        if self.shading != "none" and self.gradient == "none":
            raise VGraphError(f"{self.id}.shading: {self.shading} needs a gradient; set "
                              f"{self.id}.gradient to central (or forward, backward, sobel) or "
                              f"{self.id}.shading to none")

    # --- evaluation -----------------------------------------------------------------------------
    def process(self, volume: Volume, entry: Image, exit: Image) -> dict:
        volume.require_samples(f"RayCaster '{self.id}'")
        if entry.size != exit.size:
            raise VGraphError(f"entry image is {entry.size[0]}x{entry.size[1]} but exit image is "
                              f"{exit.size[0]}x{exit.size[1]}; connect both to one EntryExitPoints")
        ctx = self.gl
        image, depth = self._targets.ensure(ctx, entry.size)
        textures = {"entry_points": entry, "exit_points": exit,
                    "volume": volume.texture(ctx),
                    "transfer_function": self._lut.update(ctx, self.transfer_function, volume)}
        blocks = None
        if self.empty_space_skipping and self.compositing in SKIPPING:
            blocks = self._block_texture(ctx, volume)
        if blocks is not None:
            textures["blocks"] = blocks
        # Compiled once per define set; later calls are a dictionary look-up.
        program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, FRAGMENT_SHADER,
                                   self.shader_defines(skipping=blocks is not None),
                                   processor=self.id)
        sampler = linear_sampler(ctx)  # trilinear whatever the volume texture's own filter is
        sampler.use(VOLUME_UNIT)
        try:
            fullscreen_pass(ctx, program, self._targets, textures,
                            self._uniforms(volume, entry.size))
        finally:
            sampler.clear(VOLUME_UNIT)
        return {"image": image, "depth": depth}

    def _uniforms(self, volume: Volume, size) -> dict:
        geometry = VolumeGeometry.of(volume)
        min_spacing = float(geometry.spacing.min())
        scale, offset = volume.texture_scale_offset()
        to_world_scale, to_world_offset = geometry.texture_to_world
        camera = self.view_camera = view_camera(self.camera, volume, size)
        rays = ray_uniforms(camera, size)
        uniforms = {
            "texture_to_world_scale": vec(to_world_scale),
            "texture_to_world_offset": vec(to_world_offset),
            "step_length": min_spacing / self.sampling_rate,
            "opacity_exponent": 1.0 / self.sampling_rate,
            "intensity_scale": float(scale), "intensity_offset": float(offset),
            "volume_dims": tuple(int(d) for d in volume.dims),
            "early_termination": self.early_termination, "iso_level": self.iso_level,
            "background": tuple(self.background),
            "view_projection": camera.view_projection(size[0] / size[1]),
            "viewport_size": (float(size[0]), float(size[1])),
            "view_forward": vec(camera.basis()[2]),
            "near_centre": rays["near_centre"], "near_right": rays["near_right"],
            "near_up": rays["near_up"],
            **block_grid_uniforms(volume)}
        if self.shading != "none":
            uniforms.update(self._shading_uniforms(geometry, float(scale), min_spacing))
        return uniforms

    def _shading_uniforms(self, geometry: VolumeGeometry, scale: float, min_spacing: float) -> dict:
        spacings = GRADIENT_SPACINGS.get(self.gradient, 1.0)
        return {"voxel_step": vec(1.0 / geometry.dims),
                "gradient_scale": vec(scale / (spacings * geometry.spacing)),
                **shading_uniforms(self, min_spacing)}

    def _block_texture(self, ctx, volume: Volume):
        """Per-block values for SKIP_EMPTY_SPACE: skip radii from the occupancy under the current TF
        (dvr, first_hit) or iso level (iso), or the block maxima (mip); None when skipping does
        not pay."""
        kind = SKIPPING[self.compositing]
        if kind == "maximum":
            return self._blocks.texture(ctx, volume, kind, lambda low, high: high)
        if kind == "opacity":
            return self._blocks.texture(ctx, volume, (kind, self.transfer_function), lambda low, high:
                                        radii_if_worthwhile(occupied_blocks(low, high, self._lut.alpha)))
        return self._blocks.texture(ctx, volume, (kind, self.iso_level),
                                    lambda low, high: radii_if_worthwhile(high >= self.iso_level))
