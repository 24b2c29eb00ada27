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
- Oriented volumes (Volume.direction) are drawn on their axes reordered and mirrored to follow
  the world axes (vgraph.grid_axes: a view of the voxels, nothing resampled), in a frame turned by
  what rotation remains (none for a direction that only permutes and mirrors the world axes, as
  LPS and RAS files do). Volumes drawn together must be turned alike (PropertyError otherwise).
- A camera that cannot view the box at all (a Camera's limits, e.g. automatic far plane beyond
  1e15) is refused by name: PropertyError '<owner>.camera', exit 2.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from vgraph import derived
from vgraph.box_frame import BoxFrame
from vgraph.camera import Camera
from vgraph.errors import PropertyError, VGraphError
from vgraph.gl.raycasting.geometry import VolumeGeometry, box_camera, view_camera
from vgraph.grid_axes import axes_against, nearest_rotation, on_axes
from vgraph.view_geometry import as_vec3
from vgraph.volume import IDENTITY, Matrix3, Volume


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
    _check_turned_alike(volumes, owner)
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
    volume: its own box and spacing, exactly. An oriented volume's box is the world box that holds
    it (Volume.world_box)."""
    boxes = [VolumeGeometry.of(v).box if v.is_axis_aligned else v.world_box() for v in volumes]
    low, high = boxes[0]
    for box in boxes[1:]:
        low, high = np.minimum(low, box[0]), np.maximum(high, box[1])
    return low, high, min(float(np.min(volume.spacing)) for volume in volumes)


def volume_in_frame(volume: Volume, frame: BoxFrame) -> Volume:
    """``volume`` moved into ``frame`` (itself for the identity frame and an axis-aligned volume):
    the same voxels and values on its axes reordered and mirrored to follow the frame's
    (vgraph.grid_axes), on the grid spacing / scale from the frame's point of its origin, axis
    aligned there; a BrickedVolume stays bricked (its pyramid regridded, nothing read). Kept while
    the volume lives, for the last frame asked (vgraph.derived)."""
    if frame.is_identity and volume.is_axis_aligned:
        return volume
    return derived.value(volume, "volume in frame", lambda: _moved(volume, frame), params=frame)


def _moved(volume: Volume, frame: BoxFrame) -> Volume:
    moved = on_axes(volume, axes_against(volume.direction, frame.rotation))
    spacing = as_vec3(np.asarray(moved.spacing, dtype=np.float64) / frame.scale)
    origin = as_vec3(frame.points(moved.origin))
    return moved.with_overrides(spacing, origin, direction=IDENTITY)


def frame_rotation(volumes) -> Matrix3:
    """The rotation of the frame ``volumes`` are drawn in: the first volume's nearest rotation
    (vgraph.grid_axes), its own direction for a bricked volume (whose axes cannot be reordered
    for free)."""
    first = volumes[0]
    if first.bricks is None:
        return nearest_rotation(first.direction)[0]
    if np.linalg.det(np.asarray(first.direction)) < 0.0:
        raise VGraphError(f"volume from {first.source or 'a brick store'}: its axes are mirrored "
                          f"(direction {np.round(first.direction, 6).tolist()}), which a brick "
                          f"pyramid cannot be drawn with; convert it again with vgraph convert, "
                          f"which stores it on unmirrored axes")
    return first.direction


def _check_turned_alike(volumes: tuple, owner: str) -> None:
    """Refuse volumes whose grids are turned against each other by more than a reordering and
    mirroring of axes: one frame cannot draw both as boxes."""
    if all(v.is_axis_aligned for v in volumes) or len(volumes) == 1:
        return
    rotation = frame_rotation(volumes)
    for number, volume in enumerate(volumes[1:], start=2):
        if axes_against(volume.direction, rotation) is None or volume.bricks is not None \
                and rotation != volume.direction:
            raise PropertyError(f"{owner}.volume{number}",
                                f"{volume.source or 'the volume'} is turned against "
                                f"{volumes[0].source or 'the first volume'} (directions "
                                f"{np.round(volume.direction, 6).tolist()} and "
                                f"{np.round(volumes[0].direction, 6).tolist()}): volumes drawn "
                                f"together must share their axes up to order and mirroring; "
                                f"resample one onto the other's grid")


def _box_frame(volumes: tuple) -> tuple[BoxFrame, np.ndarray, np.ndarray]:
    """(the frame of the volumes' union box, its min, its max), remembered for the last volumes:
    a camera drag asks every frame for the same ones."""
    last = _last_frame[0]
    if last is not None and _same(last[0], volumes):
        return last[1]
    if all(v.is_axis_aligned for v in volumes):
        low, high, _ = rays_box(volumes)
        known = (BoxFrame.of(low, high), low, high)
    else:  # the box in the turned coordinates, where the volumes are axis-aligned
        rotation = frame_rotation(volumes)
        low, high, _ = rays_box([volume_in_frame(v, BoxFrame(rotation=rotation)) for v in volumes])
        known = (BoxFrame.of(low, high, rotation), low, high)
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
            resolved = view_camera(camera, volume_in_frame(volumes[0], frame), size) if len(volumes) == 1 \
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
