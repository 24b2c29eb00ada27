"""Volumetric shadows in the ray casters: the LightShadows component samples a light volume (the
LightVolume processor's transmittance, vgraph.numerics.light_volume; Ropinski et al. 2008) at each
shaded sample (shaders/raycasting/light_volume.glsl; rule 9 of vgraph.numerics.reference_raycast).

The ``light_volume`` inport is optional: unconnected, nothing is bound and the define
LIGHT_VOLUME is off, so the image is the unshadowed one bit for bit. Connected, the light volume
may have its own grid (another resolution, a crop) but must share the volume's orientation: the
volume's texture coordinates are mapped to the light volume's per axis (``texture_mapping``).
"""

from __future__ import annotations

import numpy as np

from vgraph.errors import VGraphError
from vgraph.gl.raycasting.geometry import vec
from vgraph.gl.raycasting.raycaster_base import Binding, Component, Frame, in_modes
from vgraph.gl.raycasting.textures import linear_sampler
from vgraph.ports import Inport
from vgraph.properties import FloatProperty
from vgraph.volume import Volume


def texture_mapping(volume: Volume, light_volume: Volume) -> tuple[np.ndarray, np.ndarray]:
    """(scale, offset) per index axis with light texture coordinate = volume texture coordinate *
    scale + offset; both grids' texture coordinate of a voxel centre u is (u + 0.5) / dims."""
    dims, spacing = np.asarray(volume.dims, float), np.asarray(volume.spacing, float)
    light_dims, light_spacing = np.asarray(light_volume.dims, float), np.asarray(light_volume.spacing, float)
    shift = np.asarray(volume.origin, float) - np.asarray(light_volume.origin, float)
    if not volume.is_axis_aligned:
        shift = np.asarray(volume.direction, float).T @ shift  # along the shared index axes
    scale = dims * spacing / (light_spacing * light_dims)
    offset = ((shift - 0.5 * spacing) / light_spacing + 0.5) / light_dims
    return scale, offset


class LightShadows(Component):
    """Shadows from an optional ``light_volume`` inport, in the ``shadowed_modes`` of the option
    ``mode`` (the RayCaster's dvr and iso); ``attach`` hands it the frame's two volumes."""

    inports = (Inport("light_volume", Volume, "transmittance of a light (LightVolume): volumetric shadows",
                      optional=True),)
    glsl = ("raycasting/light_volume.glsl",)

    def __init__(self, mode: str | None = None, shadowed_modes: tuple[str, ...] | None = None):
        self.mode, self.shadowed_modes = mode, shadowed_modes

    def start(self) -> None:
        self.volumes = None  # (volume, light volume) of this frame, or None

    def declare(self):
        return {"shadow_strength": FloatProperty(1.0, min=0.0, max=1.0,
                                                 doc="with light_volume connected: colour * (1 - strength "
                                                     "* (1 - transmittance)); 1: the light's own shadow")}

    def attach(self, volume: Volume, light_volume: Volume | None) -> None:
        """This frame's volume (world grid) and light volume (None: unconnected)."""
        if light_volume is not None and not np.allclose(volume.direction, light_volume.direction, atol=1e-9):
            raise VGraphError(f"{self.processor.id}.light_volume: {light_volume.source or 'the light volume'} "
                              f"is turned against {volume.source or 'the volume'} (other direction cosines); "
                              f"compute it from this volume (LightVolume)")
        self.volumes = None if light_volume is None else (volume, light_volume)

    def bind(self, frame: Frame) -> Binding:
        if self.volumes is None or not in_modes(self.processor, self.mode, self.shadowed_modes):
            return Binding()
        volume, light = self.volumes
        scale, offset = texture_mapping(volume, light)
        intensity_scale, intensity_offset = light.texture_scale_offset()
        return Binding(defines={"LIGHT_VOLUME": True},
                       textures={"light_volume": light.texture(frame.ctx)},
                       samplers={"light_volume": linear_sampler(frame.ctx)},
                       uniforms={"light_volume_scale": vec(scale), "light_volume_offset": vec(offset),
                                 "light_intensity_scale": float(intensity_scale),
                                 "light_intensity_offset": float(intensity_offset),
                                 "shadow_strength": self.processor.shadow_strength})
