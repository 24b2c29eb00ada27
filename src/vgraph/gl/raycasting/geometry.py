"""Where a volume is and how the camera's rays meet it: world <-> texture space, the boxes, the
near and far planes, the ray uniforms, and the concrete camera of a frame.

Conventions (docs/explanations/conventions.md has them all):

- Texture space: voxel i along an axis has its centre at texture coordinate (i + 0.5) / dims, where
  GL samples a 3D texture. A world point p maps to ``t = ((p - origin) / spacing + 0.5) / dims``
  and back to ``p = origin + (t * dims - 0.5) * spacing`` (VolumeGeometry).
- The volume's box is the box spanned by the voxel centres, ``[origin, origin + (dims - 1) *
  spacing]`` (the CPU reference's box), in texture space ``[0.5 / dims, 1 - 0.5 / dims]``. Rays
  are intersected with it grown by ``BOX_EPSILON * (max |corner| + min spacing)`` on every side
  (so rays grazing a face count as hits, as in the reference) and the stored coordinates are
  clamped back into it. EntryExitPoints rasterises a box grown by PROXY_MARGIN of its size only to
  find the pixels to compute; each fragment intersects its own ray with the box exactly.
- Camera planes: the pixel centre (ndc_x, ndc_y) lies on the near plane at ``centre + ndc_x * right
  + ndc_y * up`` (``plane_frame``), the origin of ``Camera.rays``; likewise on the far plane.
"""

from __future__ import annotations

import functools
import math
import weakref
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from vgraph.camera import Camera
from vgraph.implicit import UNIT_BOX
from vgraph.volume import Volume

BOX_EPSILON = 1e-5  # relative growth of the rasterised box (float32 version of the reference's)
PROXY_MARGIN = 0.01  # relative growth of the box EntryExitPoints rasterises (coverage only)

# A view of the implicit functions' box [-1, 1]^3 (where the FunctionSelector puts its volumes).
# It frames whatever volume arrives (fit_to_data) with automatic near/far planes.
DEFAULT_CAMERA = Camera(**{**Camera.looking_at_box(*UNIT_BOX, direction=(-0.45, -0.35, -1.0)).model_dump(),
                           "near": None, "far": None, "fit_to_data": True})


def view_camera(camera: Camera, volume: Volume, size) -> Camera:
    """The concrete camera that renders ``volume`` at ``size`` (Camera.resolved on its box): every
    processor of one view resolves the same camera, so entry points and ray casters agree."""
    last = _last_view[0]
    if last is not None and last[0] is camera and last[1]() is volume and last[2] == size:
        return last[3]  # the second processor of a frame: no hashing of the camera's fields
    resolved = box_camera(camera, *VolumeGeometry.of(volume).box, size)
    _last_view[0] = (camera, weakref.ref(volume), tuple(size), resolved)
    return resolved


def box_camera(camera: Camera, box_min, box_max, size) -> Camera:
    """Camera.resolved on a box at ``size``, remembered: the processors of one frame resolve the
    same camera (view_camera for a volume's box, framed_view for a union or a framed box). A tile
    of a picture (Camera.tile) is resolved as the whole picture is, to the last bit, and keeps
    its window."""
    whole, whole_size, _ = picture_of(camera, size)
    if whole is not camera:
        resolved = _resolved(whole, tuple(box_min), tuple(box_max), whole_size[0] / whole_size[1])
        return _windowed(resolved, camera.window)
    return _resolved(camera, tuple(box_min), tuple(box_max), size[0] / size[1])


def picture_of(camera: Camera, size) -> tuple[Camera, tuple[int, int], tuple[int, int]]:
    """(the camera of the whole picture, its size (W, H), the offset of this ``size`` image in it
    in GL window coordinates (x right, y up)) for a tile camera (Camera.tile(x, y, w, h, W, H) of
    a camera without a window); (camera, size, (0, 0)) for any other camera. The pixels of a tile
    are then computed with the whole picture's numbers (pixel_rays), so a tile is bit for bit the
    same rectangle of the whole picture (docs/guide/distributed.md)."""
    window = camera.window
    if window is None:
        return camera, tuple(size), (0, 0)
    whole = _whole_picture(window, *size)
    if whole is None:  # a window that is no tile of a picture of whole pixels: drawn as it says
        return camera, tuple(size), (0, 0)
    x, y, full_width, full_height = whole
    return _unwindowed(camera), (full_width, full_height), (x, full_height - y - size[1])


@functools.lru_cache(maxsize=64)
def _whole_picture(window: tuple, width: int, height: int) -> tuple[int, int, int, int] | None:
    """(x, y (row 0 at the top), W, H) of the tile whose Camera.tile window this is, or None."""
    left, right, bottom, top = window
    full_width, full_height = round(2.0 * width / (right - left)), round(2.0 * height / (top - bottom))
    x, y = round((left + 1.0) / 2.0 * full_width), round((1.0 - top) / 2.0 * full_height)
    if not (0 <= x and 0 <= y and x + width <= full_width and y + height <= full_height):
        return None
    exact = (-1.0 + 2.0 * x / full_width, -1.0 + 2.0 * (x + width) / full_width,
             1.0 - 2.0 * (y + height) / full_height, 1.0 - 2.0 * y / full_height)
    if max(abs(a - b) for a, b in zip(exact, window)) > 1e-9:
        return None
    return x, y, full_width, full_height


@functools.lru_cache(maxsize=32)
def _unwindowed(camera: Camera) -> Camera:
    return camera._replace(window=None)


@functools.lru_cache(maxsize=32)
def _windowed(camera: Camera, window: tuple) -> Camera:
    return camera._replace(window=window)


# (camera, volume (weakly: this must not keep a volume alive), size, resolved camera) of the last call
_last_view: list = [None]


@functools.lru_cache(maxsize=32)
def _resolved(camera: Camera, box_min: tuple, box_max: tuple, aspect: float) -> Camera:
    # Remembered: the processors of one frame resolve the same camera, each a validated model.
    return camera.resolved(np.array(box_min), np.array(box_max), aspect)


@dataclass(frozen=True)
class VolumeGeometry:
    """Where a volume's voxels are: world <-> texture space maps and boxes, float64, (x, y, z)."""

    dims: np.ndarray
    spacing: np.ndarray
    origin: np.ndarray

    @classmethod
    def of(cls, volume: Volume) -> "VolumeGeometry":
        return cls(np.array(volume.dims, dtype=np.float64),
                   np.asarray(volume.spacing, dtype=np.float64),
                   np.asarray(volume.origin, dtype=np.float64))

    @property
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """World corners of the box spanned by the voxel centres."""
        return self.origin, self.origin + (self.dims - 1.0) * self.spacing

    def grown_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The box grown by BOX_EPSILON relative to its coordinates (see the module docstring)."""
        lo, hi = self.box
        eps = BOX_EPSILON * (max(np.abs(lo).max(), np.abs(hi).max()) + self.spacing.min())
        return lo - eps, hi + eps

    def proxy_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The box EntryExitPoints rasterises: grown by PROXY_MARGIN of its size, so that it covers
        every pixel whose ray meets grown_box() despite the rasteriser's rounding."""
        lo, hi = self.grown_box()
        margin = PROXY_MARGIN * (float((hi - lo).max()) + self.spacing.min())
        return lo - margin, hi + margin

    @property
    def world_to_texture(self) -> tuple[np.ndarray, np.ndarray]:
        """(scale, offset) with t = p * scale + offset."""
        return 1.0 / (self.spacing * self.dims), (0.5 - self.origin / self.spacing) / self.dims

    @property
    def texture_to_world(self) -> tuple[np.ndarray, np.ndarray]:
        """(scale, offset) with p = t * scale + offset."""
        return self.spacing * self.dims, self.origin - 0.5 * self.spacing

    @property
    def texture_box(self) -> tuple[np.ndarray, np.ndarray]:
        return 0.5 / self.dims, 1.0 - 0.5 / self.dims


def plane_frame(camera: Camera, size, plane: str = "near") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre, right, up) of the near or far plane: the pixel centre at (ndc_x, ndc_y) lies at
    centre + ndc_x * right + ndc_y * up, as in Camera.rays (which starts its rays on the near plane)."""
    width, height = size
    aspect = width / height
    right, true_up, forward = camera.basis()
    depth = camera.near if plane == "near" else camera.far
    centre = np.asarray(camera.position, dtype=np.float64) + depth * forward
    if camera.projection == "perspective":
        half_height = depth * math.tan(math.radians(camera.fov) / 2.0)
    else:
        half_height = camera.parallel_scale
    if camera.window is None:  # the whole view (kept as it was: existing images stay bit for bit)
        return centre, half_height * aspect * right, half_height * true_up
    # A tile (Camera.tile): the full view's plane, then the window's part of it, so the image's
    # NDC (u, v) lands where the full view's (centre_x + u half_x, centre_y + v half_y) does.
    full_aspect, centre_x, centre_y, half_x, half_y = camera.window_frame(aspect)
    full_right, full_up = half_height * full_aspect * right, half_height * true_up
    return centre + centre_x * full_right + centre_y * full_up, half_x * full_right, half_y * full_up


def plane_cuts_box(camera: Camera, plane: str, box_min, box_max) -> bool:
    """Whether the near or far plane passes through the box (only then does it cap any ray)."""
    # The box's depth range along the view axis: its centre's depth +- the half-extent's reach.
    # Plain floats: asked twice a frame, where numpy's per-call cost would dominate.
    forward = camera.basis()[2].tolist()
    centre_depth = reach = 0.0
    for f, low, high, eye in zip(forward, box_min, box_max, camera.position):
        centre_depth += ((float(low) + float(high)) / 2.0 - eye) * f
        reach += abs(f) * (float(high) - float(low)) / 2.0
    plane_depth = camera.near if plane == "near" else camera.far
    return centre_depth - reach < plane_depth < centre_depth + reach


def box_corners(box_min, box_max) -> tuple[tuple[float, float, float], ...]:
    """The 8 corners of a box (for footprint)."""
    return tuple((float(x), float(y), float(z)) for x in (box_min[0], box_max[0])
                 for y in (box_min[1], box_max[1]) for z in (box_min[2], box_max[2]))


def cube_triangles() -> np.ndarray:
    """The unit cube's 12 triangles as 36 corners (0/1 per axis), float32, each triangle
    counter-clockwise seen from outside (GL's default front face is the outside)."""
    corners = []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side in (0.0, 1.0):
            quad = []
            for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
                point = np.zeros(3)
                point[axis], point[u], point[v] = side, a, b
                quad.append(point)
            normal = np.cross(quad[1] - quad[0], quad[2] - quad[0])
            if normal[axis] * (side - 0.5) < 0.0:  # points inwards: reverse the quad
                quad.reverse()
            corners += [quad[0], quad[1], quad[2], quad[0], quad[2], quad[3]]
    return np.array(corners, dtype=np.float32)


def footprint(view_projection: np.ndarray, corners, size) -> tuple[int, int, int, int] | None:
    """The pixels (x, y, width, height; GL window coordinates, y up) that the box with these
    ``corners`` (box_corners) can cover when rasterised with ``view_projection``, a pixel to spare
    on each side: the bounding rectangle of the projected corners, which holds the projection of
    every point of the box, also where the near or far plane cuts it. None when a corner lies at
    or behind the eye (no bound)."""
    # Plain floats: once a frame, where numpy's per-call cost would be most of it.
    (ax, bx, cx, dx), (ay, by, cy, dy), _, (aw, bw, cw, dw) = view_projection.tolist()
    xs, ys = [], []
    for x, y, z in corners:
        w = aw * x + bw * y + cw * z + dw
        if not w > 0.0:
            return None
        xs.append(min(max((ax * x + bx * y + cx * z + dx) / w, -2.0), 2.0))  # NDC, off-screen clamped
        ys.append(min(max((ay * x + by * y + cy * z + dy) / w, -2.0), 2.0))

    def pixels(low: float, high: float, count: int) -> tuple[int, int]:
        first = min(max(math.floor((low + 1.0) * 0.5 * count) - 1, 0), count)
        end = min(max(math.ceil((high + 1.0) * 0.5 * count) + 1, 0), count)
        return first, end - first

    (x0, width), (y0, height) = pixels(min(xs), max(xs), size[0]), pixels(min(ys), max(ys), size[1])
    return (x0, y0, width, height)


def ray_uniforms(camera: Camera, size) -> Mapping[str, tuple[float, ...]]:
    """Uniforms of the pixel rays (Camera.rays): origin near_centre + x near_right + y near_up and
    direction direction_centre + x direction_right + y direction_up (not normalised) for the pixel
    centre at NDC (x, y). Directions are given on their own, not as origin - eye, which would lose
    digits in float32 when the near plane is close to the eye. Read-only: the processors of one
    frame share the camera (view_camera) and so share these."""
    size = tuple(size)
    last = _last_rays[0]
    if last is not None and last[0] is camera and last[1] == size:
        return last[2]
    rays = MappingProxyType(_ray_uniforms(camera, size))
    _last_rays[0] = (camera, size, rays)
    return rays


_last_rays: list = [None]  # (camera, size, uniforms) of the last call: a frame asks three times


def pixel_rays(camera: Camera, size) -> Mapping[str, tuple[float, ...]]:
    """ray_uniforms of the whole picture (picture_of) with ``viewport_size`` (its size) and
    ``pixel_offset`` (where this image lies in it): the shaders take a pixel's NDC as
    ``(gl_FragCoord.xy + pixel_offset) / viewport_size * 2 - 1``, so the pixels of a tile get the
    rays of the whole picture's pixels to the last bit (with a plain camera: offset 0, bit for
    bit what ray_uniforms and the image's size give). Read-only, like ray_uniforms."""
    size = tuple(size)
    last = _last_pixel_rays[0]
    if last is not None and last[0] is camera and last[1] == size:
        return last[2]
    whole, whole_size, offset = picture_of(camera, size)
    rays = MappingProxyType({**ray_uniforms(whole, whole_size),
                             "viewport_size": (float(whole_size[0]), float(whole_size[1])),
                             "pixel_offset": (float(offset[0]), float(offset[1]))})
    _last_pixel_rays[0] = (camera, size, rays)
    return rays


_last_pixel_rays: list = [None]  # (camera, size, uniforms) of the last call


def _ray_uniforms(camera: Camera, size) -> dict[str, tuple[float, ...]]:
    near = plane_frame(camera, size, "near")
    forward = camera.basis()[2]
    if camera.projection == "perspective":  # through the near-plane point, from the eye
        # A tile's centre ray leaves the view axis: its offset on the near plane over the depth.
        off_axis = (near[0] - np.asarray(camera.position) - camera.near * forward) / camera.near
        centre = forward if camera.window is None else forward + off_axis
        directions = (centre, near[1] / camera.near, near[2] / camera.near)
    else:
        directions = (forward, np.zeros(3), np.zeros(3))
    names = ("near_centre", "near_right", "near_up", "direction_centre", "direction_right",
             "direction_up")
    return {name: vec(value) for name, value in zip(names, (*near, *directions))}



def vec(values) -> tuple[float, ...]:
    """A uniform value from a numpy vector (float64 -> Python floats; the GL side is float32)."""
    return tuple(map(float, values))
