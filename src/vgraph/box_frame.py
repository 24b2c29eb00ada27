"""A box's normalised frame: world coordinates moved by the box's centre and divided by a power of
two near its radius, so that the box is about [-1, 1]^3 there. VTK shifts and scales float32
vertex buffers the same way; here it is also what the camera is resolved in.

    frame = BoxFrame.of(box_min, box_max)
    camera_in_frame = frame.camera(camera)          # ValueError when it cannot be held there
    world = frame.world_camera(camera_in_frame)     # None when a Camera cannot hold it in world units

Why: a Camera holds coordinates within +-1e15 (vgraph.camera.MAX_COORDINATE), and the sphere it
frames is at least 1e-6 (1 + |corner|) across (view_geometry.bounding_sphere, so that a single
voxel still has a view). A mesh 1e14 across, valid in world coordinates, gets a framed camera
several radii away, beyond 1e15 (pydantic refused it); one 1e-12 across was framed as a speck in
a sphere a million times larger (a blank image). In the frame both are ordinary boxes.

A frame may also be turned (``rotation``, a proper rotation whose columns are the frame's axes in
world): volumes whose grid is tilted against the world axes (Volume.direction) are drawn in the
frame of their own axes, where their box is axis-aligned (vgraph.gl.raycasting.framed_view). A
rotation keeps lengths, angles and handedness, so cameras, rays, opacity correction and shading
are the same there.

Ordinary boxes get the identity frame (``is_identity``): radius at least 1e-5 (1 + |corner|) and
corners plus 1e4 radii within 1e15, so that any framing (fields of view down to a fraction of a
degree, narrow images) fits. For them cameras and images are bit for bit what they were. The scale
is a power of two, so scaling is exact in binary floating point; only the shift rounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vgraph.camera import MAX_COORDINATE, Camera
from vgraph.view_geometry import Vec3, as_vec3
from vgraph.volume_grid import IDENTITY, Matrix3

# The smallest radius (relative to 1 + the largest corner coordinate) framed in world units:
# ten times the least sphere bounding_sphere frames.
ORDINARY_RADIUS = 1e-5
# A framed camera lies within this many radii of the box (far plane included) for fields of view
# down to ~0.1 degree; boxes where that could pass MAX_COORDINATE are framed in their frame.
FRAMING_REACH = 1e4


@dataclass(frozen=True)
class BoxFrame:
    """frame = (rotation^T world - centre) / scale; the identity frame has centre 0, scale 1 and
    no rotation. ``centre`` is in the turned coordinates rotation^T world."""

    centre: Vec3 = (0.0, 0.0, 0.0)
    scale: float = 1.0
    rotation: Matrix3 = IDENTITY

    @classmethod
    def of(cls, box_min, box_max, rotation: Matrix3 = IDENTITY) -> "BoxFrame":
        """The frame of the box [box_min, box_max], given in the turned coordinates
        rotation^T world."""
        lo, hi = np.asarray(box_min, dtype=np.float64), np.asarray(box_max, dtype=np.float64)
        radius = float(np.linalg.norm(hi - lo)) / 2.0
        reach = float(max(np.abs(lo).max(), np.abs(hi).max()))
        if radius >= ORDINARY_RADIUS * (1.0 + reach) and reach + FRAMING_REACH * radius <= MAX_COORDINATE:
            return cls(rotation=rotation)
        scale = 2.0 ** round(math.log2(radius)) if radius > 0.0 else 1.0
        return cls(as_vec3((lo + hi) / 2.0), scale, rotation)

    @property
    def is_identity(self) -> bool:
        return self.scale == 1.0 and self.centre == (0.0, 0.0, 0.0) and not self.is_turned

    @property
    def is_turned(self) -> bool:
        return self.rotation != IDENTITY

    # --- points and lengths ---------------------------------------------------------------------
    def points(self, world: np.ndarray) -> np.ndarray:
        """World points (..., 3) in the frame, float64."""
        return (self.directions(world) - self.centre) / self.scale

    def world_points(self, framed) -> np.ndarray:
        return self.world_directions(np.asarray(framed, dtype=np.float64) * self.scale + self.centre)

    def directions(self, world) -> np.ndarray:
        """World vectors (..., 3) (normals, directions) turned into the frame; lengths kept."""
        world = np.asarray(world, dtype=np.float64)
        return world @ np.asarray(self.rotation) if self.is_turned else world

    def world_directions(self, framed) -> np.ndarray:
        framed = np.asarray(framed, dtype=np.float64)
        return framed @ np.asarray(self.rotation).T if self.is_turned else framed

    # --- cameras --------------------------------------------------------------------------------
    def camera(self, camera: Camera) -> Camera:
        """``camera`` in the frame. A camera that fits the data keeps only its direction and up
        (framing recomputes the rest), so it is placed at unit distance from the frame's origin;
        a stored one is moved and scaled whole. ValueError when the result is beyond what a Camera
        holds (a stored camera many radii from a tiny box: it sees a speck either way)."""
        if self.is_identity:
            return camera
        fields = camera.model_dump()
        fields["up"] = as_vec3(self.directions(camera.up))
        if camera.fit_to_data:
            fields.update(position=as_vec3(-self.directions(camera.basis()[2])), focus=(0.0, 0.0, 0.0),
                          parallel_scale=1.0)
        else:
            fields.update(position=as_vec3(self.points(camera.position)),
                          focus=as_vec3(self.points(camera.focus)),
                          parallel_scale=camera.parallel_scale / self.scale)
        for plane in ("near", "far"):
            if fields[plane] is not None:
                fields[plane] = fields[plane] / self.scale
        return Camera(**fields)

    def world_camera(self, framed: Camera) -> Camera | None:
        """The camera in the frame, in world units; None when a Camera cannot hold it there (a box
        near 1e15 framed from a few radii away)."""
        if self.is_identity:
            return framed
        fields = framed.model_dump()
        fields.update(position=as_vec3(self.world_points(framed.position)),
                      up=as_vec3(self.world_directions(framed.up)),
                      focus=as_vec3(self.world_points(framed.focus)),
                      parallel_scale=framed.parallel_scale * self.scale)
        for plane in ("near", "far"):
            if fields[plane] is not None:
                fields[plane] = fields[plane] * self.scale
        try:
            return Camera(**fields)
        except ValueError:
            return None
