"""CurvatureRaycaster (Cabral 2010 sec. 5.3-5.4): an iso-surface coloured by its curvature.

Conventions (docs/curvature.md explains each property with pictures):
- One inport `volume` takes what the derivative mode needs: voxel SAMPLES for the finite-difference
  modes (forward, central, filtered), B-spline COEFFICIENTS (CubicSplineProcessor output) for
  tricubic and tricubic_fast. The other kind is refused with a message saying what to insert or
  remove (vgraph.gl.curvature.check_volume_kind). EntryExitPoints accepts either kind, so the
  network reads FunctionSelector -> CubicSplineProcessor -> EntryExitPoints -> CurvatureRaycaster.
- The surface is where the reconstruction (trilinear of the samples, or the spline) crosses `level`
  (normalised like every iso level; 0.5 is the surface of every FunctionSelector volume), found by
  marching and refined by regula falsi to float precision (shaders/curvature/iso_hit.glsl).
- Curvature (Kindlmann et al. 2003) in 1/world units with the DESIGN.md sign: interior brighter,
  a sphere of radius r has k1 = k2 = +1/r. Undefined where |grad f| is too small to give the
  surface a direction (vgraph.gl.curvature.min_gradient); such hits are flagged, not coloured.
- Two GPU passes and a reduction: pass 1 (curvature_raycaster.frag.glsl) writes the curvature,
  position, depth and (internal) gradient images; for linear normalisation a min/max reduction
  runs on the GPU (RangeReduction); pass 2 (curvature_color.frag.glsl) colours. Nothing is read
  back.
- Outputs (RGBA32F, the entry image's size): `image` colour over `background` (alpha 1 where hit);
  `curvature` (k1, k2, K, flag) with flag 1 = hit and curvature defined, 0.5 = hit but undefined
  (rgb 0), 0 = miss (H = (k1 + k2) / 2); `position` world xyz, alpha 1 where hit; `depth` as the
  RayCaster's (window depth, distance from the near plane, samples evaluated, 1 where hit).
"""

from __future__ import annotations

from vgraph import (BoolProperty, CameraProperty, ColorProperty, FloatProperty, Inport,
                    Invalidation, OptionProperty, Outport, Processor, VGraphError)
from vgraph.gl.curvature import (COLORMAPS, CURVATURES, DERIVATIVES, NORMALIZATIONS,
                                 ColormapTexture, RangeReduction, check_volume_kind,
                                 derivative_defines, field_uniforms, level_occupancy,
                                 measure_defines, measure_uniforms, raw_level, shading_defines)
from vgraph.gl.passes import FULLSCREEN_VERTEX_SHADER, fullscreen_pass
from vgraph.gl.shaders import programs
from vgraph.gl.volume_rendering import (DEFAULT_CAMERA, RenderTargets, SkipBlocks, VolumeGeometry, view_camera,
                                        block_grid_uniforms, lighting_properties, linear_sampler,
                                        radii_if_worthwhile, ray_uniforms, shading_uniforms, vec,
                                        crossed_by)
from vgraph.image import Image
from vgraph.volume import Volume

SURFACE_SHADER = "curvature/curvature_raycaster.frag.glsl"
COLOR_SHADER = "curvature/curvature_color.frag.glsl"
VOLUME_UNIT = 2  # texture unit of the volume in pass 1 (entry, exit, volume, blocks)

RESOURCES = Invalidation.RESOURCES


class CurvatureRaycaster(Processor):
    """Iso-surface ray casting coloured by curvature (k1, k2, Gaussian, mean, ...)."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume), Inport("entry", Image), Inport("exit", Image)]
    outports = [Outport("image", Image), Outport("curvature", Image), Outport("position", Image),
                Outport("depth", Image)]

    camera = CameraProperty(DEFAULT_CAMERA, doc="link it to the EntryExitPoints camera")
    level = FloatProperty(0.5, min=0.0, max=1.0, doc="normalised intensity of the iso-surface")
    derivatives = OptionProperty("tricubic", choices=list(DERIVATIVES), invalidates=RESOURCES,
                                 doc="forward, central, filtered differences (voxel samples) or "
                                     "tricubic, tricubic_fast (B-spline coefficients)")
    curvature = OptionProperty("gaussian", choices=list(CURVATURES), invalidates=RESOURCES,
                               doc="the measure shown")
    normalization = OptionProperty("linear", choices=list(NORMALIZATIONS), invalidates=RESOURCES,
                                   doc="linear: by the image's largest and smallest curvature; "
                                       "exponential: with attenuation")
    attenuation = FloatProperty(1.0, min=1e-6, max=1e6,
                                doc="t of the exponential normalisation, in world units")
    colormap = OptionProperty("jet", choices=list(COLORMAPS))
    contour_width = FloatProperty(2.0, min=0.0, max=32.0,
                                  doc="pixels of the black zero-curvature contour (0: none)")
    undefined_color = ColorProperty((0.5, 0.5, 0.5, 1.0),
                                    doc="colour where the ray hit but curvature is undefined")
    sampling_rate = FloatProperty(1.0, min=0.05, max=16.0,
                                  doc="samples per voxel of the smallest spacing in the hit search")
    empty_space_skipping = BoolProperty(True, invalidates=RESOURCES,
                                        doc="skip blocks the surface cannot cross (same image)")
    shading = OptionProperty("blinn_phong", choices=["none", "blinn_phong"], invalidates=RESOURCES)
    light, light_direction, ambient, diffuse, specular, shininess = lighting_properties()
    background = ColorProperty((0.0, 0.0, 0.0, 1.0))

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._surface = RenderTargets(4)  # curvature, position, depth, gradient
        self._image = RenderTargets(1)
        self._reduction = RangeReduction()
        self._colormap = ColormapTexture()
        self._blocks = SkipBlocks()

    # --- shaders --------------------------------------------------------------------------------
    def surface_defines(self, skipping: bool | None = None) -> dict[str, bool]:
        """Defines of pass 1: the derivative mode and SKIP_EMPTY_SPACE."""
        if skipping is None:
            skipping = self.empty_space_skipping
        return {**derivative_defines(self.derivatives), "SKIP_EMPTY_SPACE": bool(skipping)}

    def color_defines(self) -> dict[str, bool]:
        """Defines of pass 2: the measure, the normalisation and the shading."""
        return {**measure_defines(self.curvature, self.normalization), **shading_defines(self)}

    def visible_content(self) -> str | None:
        volume = self.inputs.get("volume")
        return crossed_by(volume, self.level) if volume is not None else None

    # --- evaluation -----------------------------------------------------------------------------
    def process(self, volume: Volume, entry: Image, exit: Image) -> dict:
        check_volume_kind(volume, self.derivatives, f"CurvatureRaycaster '{self.id}'")
        if entry.size != exit.size:
            raise VGraphError(f"entry image is {entry.size[0]}x{entry.size[1]} but exit image is "
                              f"{exit.size[0]}x{exit.size[1]}; connect both to one EntryExitPoints")
        ctx = self.gl
        curvature, position, depth, gradient = self._surface.ensure(ctx, entry.size)
        self._render_surface(ctx, volume, entry, exit)
        image, = self._image.ensure(ctx, entry.size)
        textures = {"curvature_image": curvature, "gradient_image": gradient,
                    "position_image": position, "colormap": self._colormap.update(ctx, self.colormap)}
        if self.normalization == "linear":
            textures["curvature_range"] = self._reduction.run(
                ctx, curvature, measure_defines(self.curvature), self.id, measure_uniforms(volume))
        program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, COLOR_SHADER, self.color_defines(),
                                   processor=self.id)
        fullscreen_pass(ctx, program, image, textures, self._color_uniforms(volume))
        return {"image": image, "curvature": curvature, "position": position, "depth": depth}

    def _render_surface(self, ctx, volume: Volume, entry: Image, exit: Image) -> None:
        textures = {"entry_points": entry, "exit_points": exit, "volume": volume.texture(ctx)}
        blocks = None
        if self.empty_space_skipping:
            blocks = self._blocks.texture(ctx, volume, self.level, lambda low, high:
                                          radii_if_worthwhile(level_occupancy(self.level)(low, high)))
        if blocks is not None:
            textures["blocks"] = blocks
        program = programs.program(ctx, FULLSCREEN_VERTEX_SHADER, SURFACE_SHADER,
                                   self.surface_defines(skipping=blocks is not None),
                                   processor=self.id)
        sampler = linear_sampler(ctx)  # trilinear fetches (FD modes, the fast spline)
        sampler.use(VOLUME_UNIT)
        try:
            fullscreen_pass(ctx, program, self._surface, textures,
                            self._surface_uniforms(volume, entry.size))
        finally:
            sampler.clear(VOLUME_UNIT)

    def _surface_uniforms(self, volume: Volume, size) -> dict:
        geometry = VolumeGeometry.of(volume)
        to_world_scale, to_world_offset = geometry.texture_to_world
        camera = self.view_camera = view_camera(self.camera, volume, size)
        rays = ray_uniforms(camera, size)
        return {"texture_to_world_scale": vec(to_world_scale),
                "texture_to_world_offset": vec(to_world_offset),
                "step_length": float(geometry.spacing.min()) / self.sampling_rate,
                "raw_level": raw_level(volume, self.level),
                "view_projection": camera.view_projection(size[0] / size[1]),
                "viewport_size": (float(size[0]), float(size[1])),
                "view_forward": vec(camera.basis()[2]),
                "near_centre": rays["near_centre"], "near_right": rays["near_right"],
                "near_up": rays["near_up"],
                **field_uniforms(volume), **block_grid_uniforms(volume)}

    def _color_uniforms(self, volume: Volume) -> dict:
        uniforms = {"background": tuple(self.background),
                    "undefined_color": tuple(self.undefined_color),
                    "attenuation": self.attenuation, "contour_width": self.contour_width,
                    "eye": vec(self.view_camera.position),
                    "view_forward": vec(self.view_camera.basis()[2]),
                    "perspective": self.view_camera.projection == "perspective",
                    **measure_uniforms(volume)}
        if self.shading != "none":
            uniforms.update(shading_uniforms(self, float(min(volume.spacing))))
        return uniforms
