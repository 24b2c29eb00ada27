"""LightVolume: the transmittance of a directional light through a volume under a transfer
function, for the ray casters' volumetric shadows (Behrens & Ratering 1998; Ropinski et al. 2008,
Inviwo's LightVolume).

Conventions (the model, with its rules and errors, is vgraph.numerics.light_volume's docstring):
- ``transfer_function`` classifies the voxels as the ray caster does (link it to the RayCaster's
  transfer_function), ``light_direction`` is the world direction towards the light (link it to the
  RayCaster's, with its ``light = direction``, so the shading and the shadows come from one light).
- ``gradient_opacity`` and ``transfer_function_2d`` (off by default: the TF alone, as before)
  classify the voxels by their gradient fraction as the RayCaster's properties of those names do
  (rule 5 of the model); link them to the RayCaster's too, or the shadows come from another
  classification than the image.
- The output is a volume on the input's grid holding T in [0, 1] as 16-bit codes (declared range
  0..65535): connect it to the RayCaster's ``light_volume`` inport, or look at it in a SliceViewer.
- Computed in numpy by a slab sweep along the axis the light crosses the most voxels on; a change
  of the volume, the TF or the light direction computes it again (the scheduler re-evaluates the
  processor), the camera does not.
- A volume drawn from bricks (a store larger than memory) is refused by name.
"""

from __future__ import annotations

from vgraph import Inport, Outport, Processor, PropertyError, VectorProperty, VGraphError
from vgraph.gl.raycasting.components import palette_transfer_function
from vgraph.numerics.light_volume import light_volume
from vgraph.numerics.reference_classification import GradientClassification
from vgraph.properties import GradientOpacityProperty, TransferFunction2DProperty
from vgraph.volume import Volume


class LightVolume(Processor):
    """Transmittance of a directional light through the volume under a transfer function (shadows)."""

    category = "Volume rendering"
    inports = [Inport("volume", Volume, "the volume the RayCaster draws")]
    outports = [Outport("light_volume", Volume, "transmittance T on the volume's grid as 16-bit codes (T = value / "
                                                "65535): to RayCaster.light_volume")]
    transfer_function = palette_transfer_function()
    light_direction = VectorProperty((1.0, 1.0, 1.0), doc="world-space direction towards the light "
                                                          "(link it to the RayCaster's)")
    gradient_opacity = GradientOpacityProperty(
        None, doc="opacity factor over the gradient fraction multiplying the TF's alpha, as the "
                  "RayCaster's (link it to the RayCaster's); null: off")
    transfer_function_2d = TransferFunction2DProperty(
        None, doc="alpha over (value, gradient fraction) replacing transfer_function's, as the "
                  "RayCaster's (link it to the RayCaster's); null: off")

    def process(self, volume: Volume) -> Volume:
        who = f"LightVolume '{self.id}'"
        volume.require_samples(who)
        if volume.bricks is not None:
            raise VGraphError(f"{who}: {volume.source or 'the volume'} is held in bricks "
                              f"({' x '.join(map(str, volume.dims))} voxels); a light volume needs it in "
                              f"memory: downsample it first (VolumeResample)")
        if not any(self.light_direction):
            raise PropertyError(f"{self.id}.light_direction", f"must not be zero, got {list(self.light_direction)}")
        classification = GradientClassification(self.gradient_opacity, self.transfer_function_2d)
        return light_volume(volume, self.transfer_function, self.light_direction, classification)
