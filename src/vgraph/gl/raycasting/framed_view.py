"""The view of volumes as the ray casters draw it: in the normalised frame of their box
(vgraph.box_frame), where an extreme box is an ordinary one.

    view = framed_view(camera, volumes, size, owner)
    view.camera        # the concrete camera in the frame: what the shaders and boxes use
    view.volumes       # the volumes in the frame (themselves for an ordinary box)
    view.frame         # the BoxFrame; frame.scale world units per frame unit (depth distances)
    view.world_camera  # the concrete camera in world units (a processor's ``view_camera``), None
                       # where a Camera cannot hold it (a box near 1e15 framed from radii away)

Why: a volume's box may be anything from ~1e-14 to 1e15 across and lie anywhere within +-1e15
(vgraph.volume.check_box), but a Camera holds coordinates within +-1e15 and frames a sphere of at
least 1e-6 (1 + |corner|) (view_geometry.bounding_sphere), and float32 world coordinates keep
~7 digits. A ball 9e14 across raised pydantic's ValidationError for Camera (its framing camera
lay beyond 1e15: exit 1); one 2e-11 across was framed as a speck (a blank image blamed on the
camera). In the frame both are boxes
about [-1, 1]^3, as meshes (vgraph.gl.tetrahedra.frame) and surfaces are drawn.

- Ordinary boxes (BoxFrame.is_identity) are resolved exactly as before (geometry.view_camera for
  one volume, geometry.box_camera on the union of several) and the volumes are themselves, so
  images stay bit for bit what they were.
- Otherwise the frame is that of the union of the volumes' boxes of voxel centres (rays_box); each
  volume is copied into it (Volume.with_overrides: spacing / scale, origin moved and scaled; the
  voxels are shared, one copy per volume and frame kept while the volume lives), the camera is
  moved into it (BoxFrame.camera) and resolved on the framed box (box_camera, so tiles are
  resolved as their whole picture is). Texture coordinates, window-space depth and every ratio of
  lengths are the same in the frame, so entry and exit images, samples, opacity correction and
  shading are too; a distance in world units is the frame's times ``frame.scale``.
- A stored camera too far from a tiny box to be held in its frame is resolved in world units: it
  sees a speck either way, and the blank image is reported.
- A camera that cannot view the box at all (a Camera's limits, e.g. automatic far plane beyond
  1e15) is refused by name: PropertyError '<owner>.camera', exit 2.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from vgraph.box_frame import BoxFrame
from vgraph.camera import Camera
from vgraph.errors import PropertyError
from vgraph.gl.raycasting.geometry import VolumeGeometry, box_camera, view_camera
from vgraph.view_geometry import as_vec3
from vgraph.volume import Volume


@dataclass(frozen=True)
class FramedView:
    frame: BoxFrame
    camera: Camera
    volumes: tuple[Volume, ...]
    world_camera: Camera | None


def framed_view(camera: Camera, volumes, size, owner: str) -> FramedView:
    """The view of ``volumes`` (their union box) through ``camera`` at ``size`` (module docstring);
    ``owner`` (a processor id) names the camera in errors. Every processor of a view asks with the
    same camera and volumes and gets the same numbers."""
    volumes, size = tuple(volumes), tuple(size)
    last = _last_view[0]
    if last is not None and last[0] is camera and last[2] == size and _same(last[1], volumes):
        frame, resolved, world = last[3]  # the second processor of a frame
    else:
        frame, resolved, world = _resolved_view(camera, volumes, size, owner)
        # weakly: the memo must not keep a volume alive (nor, through FramedView, its copies)
        _last_view[0] = (camera, tuple(weakref.ref(v) for v in volumes), size, (frame, resolved, world))
    return FramedView(frame, resolved, tuple(volume_in_frame(v, frame) for v in volumes), world)


_last_view: list = [None]  # (camera, weak volumes, size, (frame, camera in it, world camera))


def _same(refs: tuple, volumes: tuple) -> bool:
    return len(refs) == len(volumes) and all(ref() is volume for ref, volume in zip(refs, volumes))


def rays_box(volumes) -> tuple[np.ndarray, np.ndarray, float]:
    """(min, max, min spacing) of the box the rays span: the union of the volumes' boxes of voxel
    centres and the smallest spacing of all of them (it scales BOX_EPSILON and the jitter). One
    volume: its own box and spacing, exactly."""
    geometries = [VolumeGeometry.of(volume) for volume in volumes]
    low, high = geometries[0].box
    for geometry in geometries[1:]:
        low, high = np.minimum(low, geometry.box[0]), np.maximum(high, geometry.box[1])
    return low, high, min(float(geometry.spacing.min()) for geometry in geometries)


def volume_in_frame(volume: Volume, frame: BoxFrame) -> Volume:
    """``volume`` moved and scaled into ``frame`` (itself for the identity frame): the same voxels
    and values on the grid spacing / scale from (origin - centre) / scale; a BrickedVolume stays
    bricked (its pyramid regridded, nothing read). Kept while the volume lives."""
    if frame.is_identity:
        return volume
    known = _copies.get(volume)
    if known is None or known[0] != frame:
        spacing = as_vec3(np.asarray(volume.spacing, dtype=np.float64) / frame.scale)
        origin = as_vec3(frame.points(volume.origin))
        known = _copies[volume] = (frame, volume.with_overrides(spacing, origin))
    return known[1]


_copies: "weakref.WeakKeyDictionary[Volume, tuple[BoxFrame, Volume]]" = weakref.WeakKeyDictionary()


def _box_frame(volumes: tuple) -> tuple[BoxFrame, np.ndarray, np.ndarray]:
    """(the frame of the volumes' union box, its min, its max), remembered for the last volumes:
    a camera drag asks every frame for the same ones."""
    last = _last_frame[0]
    if last is not None and _same(last[0], volumes):
        return last[1]
    low, high, _ = rays_box(volumes)
    known = (BoxFrame.of(low, high), low, high)
    _last_frame[0] = (tuple(weakref.ref(v) for v in volumes), known)
    return known


_last_frame: list = [None]  # (weak volumes, (frame, low, high)) of the last call


def _resolved_view(camera: Camera, volumes: tuple, size, owner: str):
    """(frame, the concrete camera in it, that camera in world units or None)."""
    frame, low, high = _box_frame(volumes)
    try:
        in_frame = frame.camera(camera)
    except ValueError:  # a stored camera many radii from a tiny box sees a speck in world units too
        frame, in_frame = BoxFrame(), camera
    try:
        if frame.is_identity:  # as before, to the last bit
            resolved = view_camera(camera, volumes[0], size) if len(volumes) == 1 \
                else box_camera(camera, low, high, size)
            return frame, resolved, resolved
        framed_low, framed_high, _ = rays_box([volume_in_frame(v, frame) for v in volumes])
        resolved = box_camera(in_frame, framed_low, framed_high, size)
    except ValueError as error:  # a Camera's limits (pydantic) or an impossible framing
        reason = error.errors()[0]["msg"] if hasattr(error, "errors") else str(error)
        raise PropertyError(f"{owner}.camera", f"cannot view the box of the volume's voxel centres "
                                               f"{low.tolist()} .. {high.tolist()} with this camera: "
                                               f"{reason}") from None
    return frame, resolved, frame.world_camera(resolved)
