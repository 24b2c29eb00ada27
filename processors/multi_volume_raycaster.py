"""MultiVolumeRayCaster: up to four volumes (channels) in one ray caster, each with its own transfer
function, on the same or on different grids in one world space (in the spirit of Voreen's
MultiVolumeRaycaster and Inviwo's MultichannelRaycaster).

Conventions (the CPU reference vgraph.numerics.multivolume_reference states the same model as formulas):
- Inports ``volume1`` (required) .. ``volume4`` (optional; any subset of 2..4 may be connected),
  and the ``entry`` and ``exit`` images of an EntryExitPoints fed with the same volumes (its
  ``volume`` = volume1, its ``volume2`` .. ``volume4`` the others, in any order): the rays span the
  UNION of the channels' boxes, so each channel is drawn whole (clipping planes and crop boxes of
  that EntryExitPoints apply to every channel). The camera is resolved on that union box
  (framed_view), as the EntryExitPoints resolves it, and an extreme union box is drawn in its
  normalised frame as the RayCaster draws one (every channel moved into it). Fed with volume1 alone, the
  EntryExitPoints gives rays of volume1's box only: the colours are still right there, but the
  other channels are cut at volume1's box.
- A ray position t (texture coordinates of volume1, outside [0, 1] where the union leaves volume1's
  box) maps to world space (VolumeGeometry) and on to each channel's texture coordinates; the two
  affine maps are combined here into one scale/offset per channel, so the shader does one
  multiply-add per channel and sample. A channel contributes nothing at points outside its own box
  of voxel centres (grown as the rays' box is): no data there, rather than its edge values smeared
  out by clamp-to-edge. With two or more channels this holds for volume1 too; a lone channel is
  never tested (its rays are its own box: exactly the RayCaster's samples).
- Samples every ``min(spacing of all channels) / sampling_rate`` world units (Sampling over all
  volumes), trilinear, each channel normalised over its own value range and classified by its own
  TF (4096-entry LUT; one TransferFunctionLut of four channels). Opacity correction per channel:
  a TF's alpha is per sample at that channel's rate 1, so ``a' = 1 - (1 - a)^(step / min(spacing
  of the channel))``.
- ``blend`` (what a pixel shows):
  ``accumulate``: the channels' samples at one point are mixed into one (Cai & Sakas 1999,
  accumulation-level intermixing) - opacity ``1 - prod(1 - a'_k)``, colour the a'-weighted mean of
  the channels' colours - and composited front to back like the RayCaster's dvr (early
  termination). Order-independent; one channel gives exactly its own sample.
  ``nearest_opaque``: the TF colour of the first sample where some channel's (uncorrected) TF
  opacity reaches ``opacity_threshold``; where several do at that sample, the most opaque (then the
  lowest-numbered) channel's; drawn opaque.
  ``maximum``: each channel's maximum intensity along the ray (a MIP per channel, over the samples
  inside its box) classified by its TF; colours added (premultiplied, ``min(sum a_k rgb_k, 1)``),
  coverage ``1 - prod(1 - a_k)``: overlapping channels add up, as in fluorescence overlays.
  With one channel accumulate equals the RayCaster's dvr and maximum its mip.
- Outputs as the RayCaster's: ``image`` (premultiplied colour over ``background``) and, on demand,
  ``depth``; the depth sample is the first with opacity (accumulate), the hit (nearest_opaque),
  the maximum of the channel with the largest classified opacity (maximum).
- ``shading`` (Blinn-Phong, the RayCaster's light properties) for accumulate (each channel's
  colour shaded with its own gradient before the mix) and nearest_opaque (the hit's channel);
  gradients by central differences one voxel of the channel away; maximum is never shaded.
- Oriented channels (Volume.direction) are drawn in the frame of volume1's axes
  (gl/raycasting/framed_view), each on its axes reordered and mirrored: their directions may differ
  by the order and sign of their axes (an LPS and a RAS file of one scan), not by a turn; such a
  channel is refused naming its inport ("mv.volume2: its axes are turned against volume1's ...;
  resample one onto the other's grid").
- The optional inport `mask` and the cut-away region (vgraph.masking) weigh each channel's sample
  as the RayCaster's do: its TF opacity (accumulate, nearest_opaque: before the threshold) or its
  intensity (maximum).
- Not here: other derivatives, empty-space skipping, bricked volumes (each channel must fit one 3D
  texture).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vgraph import FloatProperty, Inport, OptionProperty, Outport, VGraphError
from vgraph.gl.raycasting.components import (Background, CameraRays, EntryExit, FrontToBack, Sampling,
                                             TransferFunctionLut, ray_main_missed)
from vgraph.gl.raycasting.light import Light
from vgraph.gl.raycasting.mask import CutAway, Mask
from vgraph.gl.raycasting.raycaster_base import Binding, Frame, RaycasterBase
from vgraph.gl.raycasting.empty_space import visible_under
from vgraph.gl.raycasting.framed_view import frame_rotation
from vgraph.gl.raycasting.geometry import VolumeGeometry
from vgraph.gl.raycasting.targets import RenderTargets
from vgraph.gl.raycasting.textures import linear_sampler, needs_bricks
from vgraph.grid_axes import axes_against
from vgraph.image import Image
from vgraph.shown_content import voxels_under
from vgraph.volume import Volume

SHADER = "multivolume/multivolume.frag.glsl"
MAX_CHANNELS = 4
CHANNEL_PORTS = tuple(f"volume{n}" for n in range(1, MAX_CHANNELS + 1))
BLEND_MODES = ("accumulate", "nearest_opaque", "maximum")
SHADED_BLENDS = ("accumulate", "nearest_opaque")


@dataclass(frozen=True)
class Channel:
    """A connected channel: its inport number (1..4) and volume."""

    number: int
    volume: Volume

    @property
    def port(self) -> str:
        return f"volume{self.number}"


def connected_channels(raycaster: "MultiVolumeRayCaster", frame: Frame) -> list[int]:
    """The numbers of the channels of the frame being drawn, in slot order (TransferFunctionLut)."""
    return [channel.number for channel in raycaster.frame_channels]


# transfer_function1 .. 4, slot k the k-th connected channel's TF.
TRANSFER_FUNCTIONS = TransferFunctionLut(channels=MAX_CHANNELS, connected=connected_channels)


class MultiVolumeRayCaster(RaycasterBase):
    """Several volumes (channels) in one ray caster, each with its own TF; accumulate, nearest opaque or
    maximum."""

    category = "Volume rendering"
    # Which volume each TF classifies: the GUI's TF editors show that volume's histogram and value
    # scale (live/evaluator.py reads this; without it a processor's TFs get its first volume's).
    transfer_function_inports = TRANSFER_FUNCTIONS.transfer_function_inports
    inports = ([Inport("volume1", Volume, "ray positions are in this volume's texture space")]
               + [Inport(port, Volume, optional=True) for port in CHANNEL_PORTS[1:]])
    outports = [Outport("image", Image), Outport("depth", Image, on_demand=True)]
    components = (EntryExit(), CameraRays(), Sampling(over="all volumes"), TRANSFER_FUNCTIONS,
                  FrontToBack(mode="blend", corrected=("accumulate",)),
                  Light(mode="blend", shaded_modes=SHADED_BLENDS), Background(), Mask(), CutAway())

    blend = OptionProperty("accumulate", choices=list(BLEND_MODES),
                           doc="accumulate: channels mixed per sample, composited front to back; "
                               "nearest_opaque: colour of the first channel to reach opacity_threshold; "
                               "maximum: a MIP per channel, colours added")
    opacity_threshold = FloatProperty(0.5, min=0.001, max=1.0,
                                      doc="nearest_opaque: TF opacity at which a channel counts as hit")

    def __init__(self, id: str | None = None, **values):
        super().__init__(id, **values)
        self._targets = {True: RenderTargets(2), False: RenderTargets(1)}  # by: depth output wanted
        self.frame_channels: list[Channel] = []  # of the frame being drawn (connected_channels)

    def visible_content(self) -> str | None:
        """Which channels have voxels their TF shows (for the blank-image warning). Not said for
        nearest_opaque, whose threshold may hide what has some opacity."""
        if self.blend == "nearest_opaque":
            return None
        seen = []
        for port in CHANNEL_PORTS:
            volume = self.inputs.get(port)
            content = visible_under(volume, getattr(self, f"transfer_function{port[-1]}")) if volume else None
            if content:
                seen.append(f"{port}: {content}")
        return "; ".join(seen) or None

    def shown_content(self) -> list:
        """Each channel's voxels its transfer function shows (vgraph.blank_causes)."""
        return [voxels_under(port, self.inputs[port], getattr(self, f"transfer_function{port[-1]}"),
                             f"transfer_function{port[-1]}")
                for port in CHANNEL_PORTS if self.inputs.get(port) is not None]

    def process(self, volume1: Volume, volume2: Volume | None, volume3: Volume | None,
                volume4: Volume | None, entry: Image, exit: Image, mask: Volume | None = None) -> dict:
        channels = [Channel(number, volume)
                    for number, volume in enumerate((volume1, volume2, volume3, volume4), start=1)
                    if volume is not None]
        for channel in channels:
            self._check(channel)
        self._check_turned_alike(channels)
        self.parts[Mask].use(mask, volume1)
        # The rays' camera is resolved on the union box, as EntryExitPoints does, and the channels
        # are drawn in its frame.
        frame = self.frame(volume1, entry, exit, volumes=[c.volume for c in channels])
        self.frame_channels = [replace(c, volume=framed) for c, framed in zip(channels, frame.volumes)]
        with_depth = self.wants("depth")
        targets = self._targets[with_depth]
        self._targets[not with_depth].release()  # a scene keeps the images of one kind only
        outputs = dict(zip(("image", "depth"), targets.ensure(frame.ctx, entry.size)))
        own = self._channel_binding(frame, self.frame_channels)
        own.defines["DEPTH_OUTPUT"] = with_depth
        self.draw(frame, SHADER, targets, own=own, missed=ray_main_missed(self.background, with_depth))
        return outputs

    def _check(self, channel: Channel) -> None:
        volume = channel.volume
        volume.require_samples(f"MultiVolumeRayCaster '{self.id}' ({channel.port})")
        if needs_bricks(volume, self.gl):
            raise VGraphError(f"{self.id}.{channel.port}: {volume.source or 'the volume'} "
                              f"({' x '.join(map(str, volume.dims))} voxels) does not fit one GL 3D texture "
                              f"(limit {self.gl.info['GL_MAX_3D_TEXTURE_SIZE']} per axis) or its memory "
                              f"budget; the MultiVolumeRayCaster samples each channel from one texture: "
                              f"crop or downsample it, or render it alone with the RayCaster (brick by "
                              f"brick)")

    def _check_turned_alike(self, channels: list[Channel]) -> None:
        """Refuse, naming the inport, a channel whose axes are turned against volume1's by more
        than their order and mirroring: the channels are drawn in one frame (framed_view), where
        each must be a box. LPS and RAS copies are alike (vgraph.grid_axes)."""
        if len(channels) < 2 or all(channel.volume.is_axis_aligned for channel in channels):
            return
        rotation = frame_rotation([channel.volume for channel in channels])
        first = channels[0].volume
        for channel in channels[1:]:
            volume = channel.volume
            if axes_against(volume.direction, rotation) is None:
                raise VGraphError(f"{self.id}.{channel.port}: its axes are turned against volume1's "
                                  f"(directions {np.round(volume.direction, 6).tolist()} and "
                                  f"{np.round(first.direction, 6).tolist()}): the channels are drawn "
                                  f"in one frame, which holds grids whose axes differ only in order "
                                  f"and mirroring; resample one onto the other's grid (e.g. "
                                  f"nibabel.processing.resample_from_to)")

    def _channel_binding(self, frame: Frame, channels: list[Channel]) -> Binding:
        """The blend, and the channels' volume textures and uniform arrays (their transfer
        functions come with TransferFunctionLut). Shader slot k (0-based) holds the k-th
        connected channel, whatever its inport number."""
        binding = Binding(defines={f"BLEND_{self.blend.upper()}": True})
        rows = [channel_uniforms(frame.geometry, channel.volume) for channel in channels]
        names = rows[0].keys() if self.shaded() else UNSHADED_UNIFORMS
        binding.uniforms.update({name: np.asarray([row[name] for row in rows], dtype=np.float32)
                                 for name in names})
        for slot, channel in enumerate(channels, start=1):
            binding.textures[f"volume{slot}"] = channel.volume.texture(frame.ctx)
            binding.samplers[f"volume{slot}"] = linear_sampler(frame.ctx)
        if self.blend == "nearest_opaque":
            binding.uniforms["opacity_threshold"] = self.opacity_threshold
        return binding


UNSHADED_UNIFORMS = ("channel_scale", "channel_offset", "channel_low", "channel_high", "channel_intensity")


def channel_uniforms(rays: VolumeGeometry, volume: Volume) -> dict[str, object]:
    """One channel's row of the uniform arrays of multivolume/channels.glsl (UNSHADED_UNIFORMS, and
    for shading channel_voxel_step and channel_gradient_scale)."""
    geometry = VolumeGeometry.of(volume)
    scale, offset = channel_map(rays, geometry)
    low, high = channel_texture_box(geometry)
    intensity_scale, intensity_offset = volume.texture_scale_offset()
    own_spacing = float(geometry.spacing.min())
    # Central differences per world unit, rescaled so that shading.glsl's threshold on |g| (set
    # for the rays' volume's spacing) tests each channel's own (channels.glsl says why).
    gradient_scale = intensity_scale / (2.0 * geometry.spacing) * own_spacing / float(rays.spacing.min())
    return {"channel_scale": scale, "channel_offset": offset, "channel_low": low, "channel_high": high,
            "channel_intensity": (intensity_scale, intensity_offset),
            "channel_voxel_step": 1.0 / geometry.dims, "channel_gradient_scale": gradient_scale}


def channel_map(rays: VolumeGeometry, channel: VolumeGeometry) -> tuple[np.ndarray, np.ndarray]:
    """(scale, offset) taking texture coordinates of the rays' volume to the channel's:
    t_channel = t * scale + offset (texture -> world of the first volume, world -> texture of the
    channel). The identity, exactly, for a channel on the rays' own grid."""
    if _same_grid(rays, channel):
        return np.ones(3), np.zeros(3)
    to_world_scale, to_world_offset = rays.texture_to_world
    to_texture_scale, to_texture_offset = channel.world_to_texture
    return to_world_scale * to_texture_scale, to_world_offset * to_texture_scale + to_texture_offset


def channel_texture_box(channel: VolumeGeometry) -> tuple[np.ndarray, np.ndarray]:
    """The channel's grown box of voxel centres (VolumeGeometry.grown_box) in its texture space."""
    scale, offset = channel.world_to_texture
    low, high = channel.grown_box()
    return low * scale + offset, high * scale + offset


def _same_grid(a: VolumeGeometry, b: VolumeGeometry) -> bool:
    return all(np.array_equal(x, y)
               for x, y in ((a.dims, b.dims), (a.spacing, b.spacing), (a.origin, b.origin)))
