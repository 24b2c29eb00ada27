"""Clipping planes and the crop box: which part of a volume the rays see (EntryExitPoints).

The model (the GL entry points and the CPU reference both follow it):

- A clip plane is a ``normal`` and a ``point`` in world units. It KEEPS the points p with
  ``dot(p - point, normal) >= 0``: the normal points into the part that stays, as for OpenGL's
  gl_ClipDistance and VTK's clipping planes. A zero normal is refused. Up to MAX_CLIP_PLANES
  planes; the kept region is the intersection of their half-spaces.
- The crop box is ``(x_min, y_min, z_min, x_max, y_max, z_max)`` in world units (not voxel
  indices: the same units as the planes and the camera); the kept region is its intersection with
  the box of the voxel centres. None means no crop.
- Each ray's interval [t_entry, t_exit] is intersected with every half-space (and the box with the
  crop box) BEFORE any sample is taken: a ray caster samples from the new entry point, so a cut
  shows the inside of the volume (capping: the ray starts on the plane). Rays left with an empty
  interval show the background. Shading keeps the volume's own gradient at the cut (as Voreen and
  ParaView do): the cut face is lit like the material it cuts through, not like a flat plane.
"""

from __future__ import annotations

from typing import Annotated

import numpy as np
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, field_validator

from vgraph.properties import Property, VectorProperty

MAX_CLIP_PLANES = 8  # the size of the shader's uniform arrays

_Finite = Annotated[float, Field(allow_inf_nan=False)]
_Vector = tuple[_Finite, _Finite, _Finite]


class ClipPlane(BaseModel):
    """One plane: keeps the half-space the normal points into (module docstring)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    normal: _Vector
    point: _Vector = (0.0, 0.0, 0.0)

    @field_validator("normal")
    @classmethod
    def _nonzero(cls, normal):
        if not any(normal):
            raise ValueError("a clip plane's normal must not be zero (it says which side is kept)")
        return normal

    def unit_normal(self) -> np.ndarray:
        normal = np.asarray(self.normal, dtype=np.float64)
        return normal / np.linalg.norm(normal)

    def offset(self) -> float:
        """d with the plane dot(p, unit normal) = d; kept: dot(p, unit normal) >= d."""
        return float(self.unit_normal() @ np.asarray(self.point, dtype=np.float64))

    def moved(self, distance: float) -> "ClipPlane":
        """The plane moved ``distance`` world units along its normal (positive: into the kept side,
        so less is kept)."""
        point = np.asarray(self.point, dtype=np.float64) + distance * self.unit_normal()
        return self.model_copy(update={"point": tuple(float(v) for v in point)})


class ClipPlanesProperty(Property):
    """A list of clip planes, each ``{"normal": [x, y, z], "point": [x, y, z]}`` in world units
    (point defaults to the origin); an empty list clips nothing."""

    kind = "clip_planes"

    def _value_type(self):
        return Annotated[tuple[ClipPlane, ...], Field(max_length=MAX_CLIP_PLANES)]


def _ordered(box):
    if box is not None and any(box[axis] > box[axis + 3] for axis in range(3)):
        raise ValueError("a crop box is (x_min, y_min, z_min, x_max, y_max, z_max) with each min "
                         "<= its max")
    return box


class CropBoxProperty(VectorProperty):
    """An optional axis-aligned box (x_min, y_min, z_min, x_max, y_max, z_max), world units."""

    def __init__(self, **kw):
        super().__init__(None, size=6, optional=True, **kw)

    def _value_type(self):
        return Annotated[super()._value_type(), AfterValidator(_ordered)]


# --- the model in numbers -----------------------------------------------------------------------
def cropped_box(box_min, box_max, crop_box) -> tuple[np.ndarray, np.ndarray] | None:
    """The box of the voxel centres intersected with the crop box (None: no crop); None when
    nothing is left."""
    lo, hi = np.asarray(box_min, dtype=np.float64), np.asarray(box_max, dtype=np.float64)
    if crop_box is not None:
        lo = np.maximum(lo, np.asarray(crop_box[:3], dtype=np.float64))
        hi = np.minimum(hi, np.asarray(crop_box[3:], dtype=np.float64))
    return None if np.any(lo > hi) else (lo, hi)


def crop_planes(crop_box) -> tuple[ClipPlane, ...]:
    """The crop box as the six planes that keep its inside: how it cuts a volume drawn in a turned
    frame (vgraph.box_frame), where a box along the world axes is not one along the frame's."""
    low, high = crop_box[:3], crop_box[3:]
    planes = []
    for axis in range(3):
        normal = [0.0, 0.0, 0.0]
        normal[axis] = 1.0
        planes.append(ClipPlane(normal=tuple(normal), point=tuple(low)))
        normal[axis] = -1.0
        planes.append(ClipPlane(normal=tuple(normal), point=tuple(high)))
    return tuple(planes)


def plane_uniforms(planes, frame=None) -> dict[str, np.ndarray]:
    """The shader's uniform arrays (float32): unit normals and offsets d (kept: dot(p, n) >= d).
    ``frame`` (a vgraph.box_frame.BoxFrame, where an extreme or tilted box is drawn): the planes in
    it, p' = (R^T p - centre) / scale, so n' = R^T n and d' = (d - dot(centre, n')) / scale."""
    normals = np.array([plane.unit_normal() for plane in planes], dtype=np.float64)
    offsets = np.array([plane.offset() for plane in planes], dtype=np.float64)
    if frame is not None and not frame.is_identity and len(planes):
        normals = frame.directions(normals)
        offsets = (offsets - normals @ np.asarray(frame.centre, dtype=np.float64)) / frame.scale
    return {"clip_normals": normals.astype(np.float32), "clip_offsets": offsets.astype(np.float32)}


def clip_intervals(origins, directions, t_entry, t_exit, planes):
    """Ray intervals [t_entry, t_exit] (rays origins + t * directions, (N, 3)) cut to the kept
    side of every plane. Empty intervals come out with t_exit < t_entry (misses)."""
    t_entry = np.array(t_entry, dtype=np.float64)
    t_exit = np.array(t_exit, dtype=np.float64)
    for plane in planes:
        normal, offset = plane.unit_normal(), plane.offset()
        height = origins @ normal - offset  # signed distance of each ray's origin: >= 0 is kept
        rate = directions @ normal
        with np.errstate(divide="ignore", invalid="ignore"):
            crossing = -height / rate
        entering, leaving = rate > 0.0, rate < 0.0
        t_entry[entering] = np.maximum(t_entry[entering], crossing[entering])
        t_exit[leaving] = np.minimum(t_exit[leaving], crossing[leaving])
        removed = (rate == 0.0) & (height < 0.0)  # parallel to the plane, on the removed side
        t_exit[removed] = -np.inf
    return t_entry, t_exit


def kept_voxels(volume, planes=(), crop_box=None) -> np.ndarray:
    """Boolean [z, y, x] mask of the voxels whose centres (in the world, through the volume's
    affine) the planes and the crop box keep (what a clipped render should equal: the volume with
    the rest set to zero)."""
    nx, ny, nz = volume.dims
    z, y, x = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    points = volume.voxel_to_world(np.stack([x, y, z], axis=-1))
    keep = np.ones((nz, ny, nx), dtype=bool)
    for plane in planes:
        keep &= points @ plane.unit_normal() >= plane.offset()
    if crop_box is not None:
        keep &= np.all((points >= np.asarray(crop_box[:3])) & (points <= np.asarray(crop_box[3:])), axis=-1)
    return keep
