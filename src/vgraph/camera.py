"""The camera: a pydantic model that is also the value of every `camera` property.

JSON form (world units)::

    {"projection": "perspective", "position": [x, y, z], "focus": [x, y, z], "up": [x, y, z],
     "fov": 30, "parallel_scale": 1, "near": null, "far": null, "fit_to_data": false}

``fov`` is the vertical field of view in degrees (perspective); ``parallel_scale`` is half the
height of the view in world units (orthographic), as in VTK.

A tile of the view (``tile(x, y, w, h, W, H)``: one rectangle of a W x H picture rendered on its
own, docs/guide/distributed.md) adds ``"window": [left, right, bottom, top]``, the rectangle in the full
view's NDC; the projection, the rays and the ray uniforms map it onto the whole image (an off-axis
sub-frustum) so its pixel centres are the full picture's. Without a window the key is not written.

Automatic parts (the renderers apply them every frame through ``resolved(box_min, box_max,
aspect)``, against the box of the data they draw):
- ``near``/``far`` None (the default): planes enclosing the data's bounding sphere from where the
  camera stands, as VTK's ResetCameraClippingRange; a number is kept as given.
- ``fit_to_data`` True: the camera keeps its direction and up and frames whatever data arrives
  (``framing``). The processors' default cameras do this; a stored camera (False) stays as stored.
- ``viewed_from(name)``: a named view (``VIEW_NAMES``: front, back, left, right, top, bottom, iso
  and the medical aliases anterior, posterior, superior, inferior) that fits the data.

Conventions (the GL renderers and the CPU reference ray caster all rely on them):

- Right-handed world. The camera frame is ``forward = normalize(focus - position)``,
  ``right = normalize(forward x up)``, ``true_up = right x forward`` (gluLookAt). ``up`` need not be
  orthogonal to the viewing direction; only its component orthogonal to it is used.
- ``view_matrix()`` is gluLookAt, ``projection_matrix(aspect)`` is gluPerspective (vertical ``fov``)
  or glOrtho(-s*aspect, s*aspect, -s, s, near, far) with ``s = parallel_scale``; OpenGL clip
  conventions (eye looks down -z, NDC z = -1 at the near plane, +1 at the far plane).
  ``aspect`` = image width / height.
- The matrices are 4x4 float64 numpy arrays acting on column vectors (``clip = M @ [x, y, z, 1]``),
  stored row-major. GLSL ``mat4`` uniforms are column-major, so upload them transposed:
  ``program["u_mvp"].write(matrix.T.astype("f4").tobytes())``.
- ``rays(width, height)`` gives one ray per pixel through the pixel CENTRE, row 0 at the TOP of the
  image: ``ndc_x = (col + 0.5) / W * 2 - 1``, ``ndc_y = 1 - (row + 0.5) / H * 2``. Origins lie on the
  near plane (t = 0 is the near plane); directions are unit vectors. A GL fragment at
  ``gl_FragCoord.xy`` has the same NDC; GL images are read back bottom row first, so flip them.
- Interaction (the GUI calls these; each returns a new, validated Camera, the model is frozen):
  ``rotate(dx, dy)`` orbits around the focus by angles in radians such that the scene turns with
  the mouse (dx > 0: drag right, dy > 0: drag UP); a GUI typically uses
  ``angle = pi * pixels / viewport_height`` (Qt's y axis points down: negate dy).
  ``pan(dx, dy)`` moves position and focus in the view plane by fractions of the visible height at
  the focus distance, so ``pan(dx_px / height_px, -dy_px / height_px)`` keeps the point under the
  cursor (at focus depth) under the cursor. ``zoom(factor)`` with factor > 1 magnifies: perspective
  dollies towards the focus (distance / factor, near and far move with the camera), orthographic
  divides ``parallel_scale``. ``framing(box_min, box_max, aspect)`` centres the box and fits its
  bounding sphere into the view with near/far enclosing it.
"""

from __future__ import annotations

import functools
import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_serializer, model_validator

from vgraph.view_geometry import (Vec3, as_vec3, bounding_sphere, clipping_range, frame_basis,
                                  rotation_matrix, unit_vector)

# Beyond this magnitude the float32 matrices and ray uniforms of the GL side overflow or lose the
# scene entirely; world coordinates and lengths of a camera are refused past it.
MAX_COORDINATE = 1e15


class Camera(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    projection: Literal["perspective", "orthographic"] = "perspective"
    position: Vec3 = (0.0, 0.0, 3.0)
    focus: Vec3 = (0.0, 0.0, 0.0)
    up: Vec3 = (0.0, 1.0, 0.0)
    fov: float = Field(30.0, gt=0.0, lt=180.0, allow_inf_nan=False)
    parallel_scale: float = Field(1.0, gt=0.0, le=MAX_COORDINATE, allow_inf_nan=False)
    near: float | None = Field(None, gt=0.0, le=MAX_COORDINATE, allow_inf_nan=False)
    far: float | None = Field(None, gt=0.0, le=MAX_COORDINATE, allow_inf_nan=False)
    fit_to_data: bool = False
    # The part of the full view this camera renders, (left, right, bottom, top) in the full view's
    # NDC; None = all of it. Set by tile() for rendering one rectangle of an image on its own
    # (docs/guide/distributed.md); saved only when set, so stored networks keep their form.
    window: tuple[float, float, float, float] | None = None

    @model_serializer(mode="wrap")
    def _drop_default_window(self, handler):
        data = handler(self)
        if self.window is None:
            data.pop("window", None)
        return data

    @model_validator(mode="after")
    def _check_geometry(self) -> "Camera":
        # Plain floats, not numpy: every camera a drag makes passes here (numpy's 3-vector calls
        # cost tens of microseconds each).
        for name in ("position", "focus", "up"):
            values = getattr(self, name)
            if not all(math.isfinite(v) for v in values):
                raise ValueError(f"{name} must be finite, got {list(values)}")
            if max(abs(v) for v in values) > MAX_COORDINATE:
                raise ValueError(f"{name} must lie within +-{MAX_COORDINATE:g} (float32 GL matrices "
                                 f"overflow beyond), got {list(values)}")
        (vx, vy, vz), (ux, uy, uz) = (f - p for f, p in zip(self.focus, self.position)), self.up
        view = math.hypot(vx, vy, vz)
        if view == 0.0:
            raise ValueError("position and focus must differ")
        across = math.hypot(vy * uz - vz * uy, vz * ux - vx * uz, vx * uy - vy * ux)
        if across <= 1e-12 * view * max(math.hypot(ux, uy, uz), 1e-300):
            raise ValueError("up must not be parallel to the viewing direction (or zero)")
        if self.near is not None and self.far is not None and not self.near < self.far:
            raise ValueError(f"near ({self.near}) must be smaller than far ({self.far})")
        if self.window is not None:
            left, right, bottom, top = self.window
            if not (all(math.isfinite(v) for v in self.window) and left < right and bottom < top):
                raise ValueError(f"window (left, right, bottom, top) must be finite with left < right "
                                 f"and bottom < top, got {list(self.window)}")
        return self

    # --- frame ----------------------------------------------------------------------------------
    @property
    def distance(self) -> float:
        """Distance from position to focus (world units)."""
        return float(np.linalg.norm(np.subtract(self.focus, self.position)))

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Orthonormal (right, true_up, forward) of the camera, float64, as in gluLookAt
        (read-only arrays: they are shared by every camera with the same position, focus, up)."""
        return frame_basis(self.position, self.focus, self.up)

    def visible_half_height(self) -> float:
        """Half the height of the view in world units at the focus distance."""
        if self.projection == "orthographic":
            return self.parallel_scale
        return self.distance * math.tan(math.radians(self.fov) / 2.0)

    def planes(self) -> tuple[float, float]:
        """(near, far); ValueError while either is automatic (None): resolved() sets them."""
        if self.near is None or self.far is None:
            raise ValueError("this camera's near and far planes are automatic (None): use "
                             "camera.resolved(box_min, box_max, aspect) to get the camera for a box")
        return self.near, self.far

    # --- tiles ----------------------------------------------------------------------------------
    def tile(self, x: int, y: int, width: int, height: int, full_width: int, full_height: int) -> "Camera":
        """The camera that renders pixels [x, x + width) x [y, y + height) (row 0 at the top) of the
        full_width x full_height image of this camera, as an image of width x height: the off-axis
        sub-frustum whose pixel centres are the full image's. Automatic parts (fit_to_data, near
        and far) stay automatic and resolve as for the full image (resolved() uses the full
        aspect), so every tile frames the data alike. A tile of a tile is a tile of the full view."""
        full_width, full_height = _check_size(full_width, full_height)
        width, height = _check_size(width, height)
        if not (0 <= x and 0 <= y and x + width <= full_width and y + height <= full_height):
            raise ValueError(f"tile {width}x{height} at ({x}, {y}) is not inside the "
                             f"{full_width}x{full_height} image")
        left, right, bottom, top = self.window or (-1.0, 1.0, -1.0, 1.0)
        span_x, span_y = right - left, top - bottom
        window = (left + span_x * x / full_width, left + span_x * (x + width) / full_width,
                  top - span_y * (y + height) / full_height, top - span_y * y / full_height)
        return self._replace(window=window)

    def window_frame(self, aspect: float) -> tuple[float, float, float, float, float]:
        """(full_aspect, centre_x, centre_y, half_x, half_y) for an image of ``aspect`` drawn
        through this camera: the image's NDC (u, v) is the full view's (centre_x + u half_x,
        centre_y + v half_y), and the full view's aspect is aspect * half_y / half_x."""
        aspect = _check_aspect(aspect)
        if self.window is None:
            return aspect, 0.0, 0.0, 1.0, 1.0
        left, right, bottom, top = self.window
        half_x, half_y = (right - left) / 2.0, (top - bottom) / 2.0
        return aspect * half_y / half_x, (left + right) / 2.0, (bottom + top) / 2.0, half_x, half_y

    # --- matrices -------------------------------------------------------------------------------
    def view_matrix(self) -> np.ndarray:
        """World -> eye coordinates (gluLookAt): the eye at the origin looking down -z."""
        right, true_up, forward = self.basis()
        matrix = np.eye(4)
        matrix[0, :3], matrix[1, :3], matrix[2, :3] = right, true_up, -forward
        matrix[:3, 3] = -matrix[:3, :3] @ np.asarray(self.position, dtype=np.float64)
        return matrix

    def projection_matrix(self, aspect: float) -> np.ndarray:
        """Eye -> clip coordinates with OpenGL conventions (gluPerspective / glOrtho)."""
        aspect, centre_x, centre_y, half_x, half_y = self.window_frame(aspect)
        n, f = self.planes()
        matrix = np.zeros((4, 4))
        if self.projection == "perspective":
            cot = 1.0 / math.tan(math.radians(self.fov) / 2.0)
            matrix[0, 0], matrix[1, 1] = cot / aspect, cot
            matrix[2, 2], matrix[2, 3] = (f + n) / (n - f), 2.0 * f * n / (n - f)
            matrix[3, 2] = -1.0
        else:
            s = self.parallel_scale
            matrix[0, 0], matrix[1, 1] = 1.0 / (s * aspect), 1.0 / s
            matrix[2, 2], matrix[2, 3] = -2.0 / (f - n), -(f + n) / (f - n)
            matrix[3, 3] = 1.0
        if self.window is not None:  # the window's NDC become the image's (x' = (x - c w) / h)
            matrix[0] = (matrix[0] - centre_x * matrix[3]) / half_x
            matrix[1] = (matrix[1] - centre_y * matrix[3]) / half_y
        return matrix

    def view_projection(self, aspect: float) -> np.ndarray:
        """World -> clip coordinates: projection_matrix(aspect) @ view_matrix() (read-only: shared
        by the renderers of one frame, which each ask for it)."""
        return _view_projection(self, aspect)

    # --- rays -----------------------------------------------------------------------------------
    def rays(self, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """(origins, directions), each (height, width, 3) float64: one ray per pixel centre, row 0
        at the top, origins on the near plane, unit directions (see the module docstring)."""
        width, height = _check_size(width, height)
        aspect = width / height
        ndc_x = (np.arange(width) + 0.5) / width * 2.0 - 1.0
        ndc_y = 1.0 - (np.arange(height) + 0.5) / height * 2.0
        if self.window is not None:  # the same pixel centres in the full view's NDC
            aspect, centre_x, centre_y, half_x, half_y = self.window_frame(aspect)
            ndc_x, ndc_y = centre_x + ndc_x * half_x, centre_y + ndc_y * half_y
        right, true_up, forward = self.basis()
        eye = np.asarray(self.position, dtype=np.float64)
        if self.projection == "perspective":
            tan_half = math.tan(math.radians(self.fov) / 2.0)
            # Point on the plane at depth 1 in front of the eye; the near plane is `near` times it.
            to_plane = (forward + (ndc_x[None, :, None] * tan_half * aspect) * right
                        + (ndc_y[:, None, None] * tan_half) * true_up)
            origins = eye + self.planes()[0] * to_plane
            directions = to_plane / np.linalg.norm(to_plane, axis=-1, keepdims=True)
        else:
            s = self.parallel_scale
            origins = (eye + self.planes()[0] * forward + (ndc_x[None, :, None] * s * aspect) * right
                       + (ndc_y[:, None, None] * s) * true_up)
            directions = np.broadcast_to(forward, origins.shape).copy()
        return origins, directions

    def far_distance(self, directions: np.ndarray) -> np.ndarray:
        """Ray parameter of the far plane for rays from rays() with these unit directions."""
        _, _, forward = self.basis()
        near, far = self.planes()
        return (far - near) / (np.asarray(directions) @ forward)

    # --- interaction ----------------------------------------------------------------------------
    def rotate(self, dx: float, dy: float) -> "Camera":
        """Orbit around the focus by dx radians about the camera's up axis and dy radians about its
        right axis, so the scene turns with the mouse (dx > 0 right, dy > 0 up). The distance to
        the focus is kept; the stored up becomes the rotated, orthonormal up."""
        _check_finite(dx=dx, dy=dy)
        right, true_up, _ = self.basis()
        # The camera moves opposite to the drag: left for a drag right, down for a drag up.
        rotation = rotation_matrix(right, dy) @ rotation_matrix(true_up, -dx)
        offset = np.subtract(self.position, self.focus, dtype=np.float64)
        position = np.asarray(self.focus) + rotation @ offset
        return self._replace(position=as_vec3(position), up=as_vec3(rotation @ true_up))

    def zoom(self, factor: float) -> "Camera":
        """Magnify by ``factor`` (> 1 zooms in). Perspective: dolly to distance / factor, moving near
        and far with the camera (near stays positive); orthographic: parallel_scale / factor."""
        _check_finite(factor=factor)
        if factor <= 0.0:
            raise ValueError(f"zoom factor must be positive, got {factor}")
        if self.projection == "orthographic":
            return self._replace(parallel_scale=self.parallel_scale / factor)
        _, _, forward = self.basis()
        new_distance = self.distance / factor
        position = np.asarray(self.focus) - new_distance * forward
        if self.near is None or self.far is None:  # automatic planes follow by themselves
            return self._replace(position=as_vec3(position))
        shift = new_distance - self.distance  # the camera moves by -shift along forward
        far = max(self.far + shift, self.far * 1e-3)  # stays positive in odd set-ups
        near = max(self.near + shift, far * 1e-4)
        return self._replace(position=as_vec3(position), near=near, far=far)

    def pan(self, dx: float, dy: float) -> "Camera":
        """Move position and focus in the view plane so the scene moves by (dx, dy) times the
        visible height at the focus distance (dx > 0 right, dy > 0 up)."""
        _check_finite(dx=dx, dy=dy)
        right, true_up, _ = self.basis()
        height = 2.0 * self.visible_half_height()
        shift = -(dx * right + dy * true_up) * height
        return self._replace(position=as_vec3(np.add(self.position, shift)),
                             focus=as_vec3(np.add(self.focus, shift)))

    def framing(self, box_min, box_max, aspect: float = 1.0) -> "Camera":
        """Keep direction and up; put the focus at the box centre and the camera at a distance
        where the box's bounding sphere fits the view (for both projections: fov and
        parallel_scale are both set, so switching projection keeps the picture); near and far
        enclose the sphere."""
        aspect = _check_aspect(aspect)
        centre, radius = bounding_sphere(box_min, box_max)
        half_v = math.radians(self.fov) / 2.0
        half_angle = min(half_v, math.atan(aspect * math.tan(half_v)))
        distance = radius / math.sin(half_angle)
        _, _, forward = self.basis()
        position, focus = as_vec3(centre - distance * forward), as_vec3(centre)
        framed = {"position": position, "focus": focus, "parallel_scale": radius * max(1.0, 1.0 / aspect)}
        # The clipping range from the framed camera's own basis (as withclipping_range() of it),
        # without validating a camera in between.
        planes = clipping_range(position, frame_basis(position, focus, self.up)[2], box_min, box_max)
        if planes is not None:
            framed["near"], framed["far"] = planes
        return self._replace(**framed)

    def withclipping_range(self, box_min, box_max) -> "Camera":
        """Near and far enclosing the box's bounding sphere from the current position (like VTK's
        ResetCameraClippingRange); near stays positive when the camera is inside. Unchanged if the
        box is entirely behind the camera."""
        planes = clipping_range(self.position, self.basis()[2], box_min, box_max)
        return self if planes is None else self._replace(near=planes[0], far=planes[1])

    def resolved(self, box_min, box_max, aspect: float = 1.0) -> "Camera":
        """The concrete camera a renderer uses for a box: framed when ``fit_to_data``, automatic
        near/far planes enclosing the box from where the camera stands (explicit ones are kept).
        The result is a stored camera (fit_to_data False, both planes set); every renderer of a
        view resolves the same camera against the same box, so their rays agree. ``aspect`` is
        the image's; a tile frames with its full view's aspect (window_frame)."""
        # A tile frames the data as the full image does: with the full view's aspect.
        full_aspect = self.window_frame(aspect)[0]
        camera = self.framing(box_min, box_max, full_aspect) if self.fit_to_data else self
        near, far = self.near, self.far
        if near is None or far is None:
            auto_near, auto_far = camera._automatic_planes(box_min, box_max)
            near = auto_near if near is None else near
            far = auto_far if far is None else far
            if near >= far:  # an explicit plane beyond the automatic other one
                far, near = (near * 2.0, near) if self.far is None else (far, far * 1e-4)
        return camera._replace(near=near, far=far, fit_to_data=False)

    def _automatic_planes(self, box_min, box_max) -> tuple[float, float]:
        planes = clipping_range(self.position, self.basis()[2], box_min, box_max)
        if planes is not None:
            return planes
        # The box is behind the camera: nothing shows, any planes do.
        scale = self.distance + bounding_sphere(box_min, box_max)[1]
        return scale * 1e-4, scale

    def viewed_from(self, name: str) -> "Camera":
        """This camera turned to a named view (VIEWS, or a medical alias in VIEW_ALIASES), framing
        the data (fit_to_data) with automatic near/far; projection and fov are kept."""
        key = VIEW_ALIASES.get(name, name)
        if key not in VIEWS:
            raise ValueError(f"unknown view '{name}'; choose one of {', '.join(VIEW_NAMES)}")
        towards_eye, up = (np.asarray(v, dtype=np.float64) for v in VIEWS[key])
        position = np.asarray(self.focus) + unit_vector(towards_eye) * self.distance
        return self._replace(position=as_vec3(position), up=as_vec3(up), near=None, far=None,
                             fit_to_data=True)

    @classmethod
    def looking_at_box(cls, box_min, box_max, direction=(0.0, 0.0, -1.0), up=(0.0, 1.0, 0.0),
                       projection: str = "perspective", aspect: float = 1.0, **fields) -> "Camera":
        """A camera viewing along ``direction`` that frames the box (see framing())."""
        centre, radius = bounding_sphere(box_min, box_max)
        start = cls(projection=projection, position=as_vec3(centre - np.asarray(direction, float)),
                    focus=as_vec3(centre), up=tuple(up), **fields)
        return start.framing(box_min, box_max, aspect)

    def _replace(self, **changes) -> "Camera":
        # Re-validated construction (model_copy(update=...) would skip the validators).
        return type(self)(**{**self.model_dump(), **changes})


# Named views: (direction from the focus towards the eye, up), in world axes. World axes are the
# volume's index axes (nothing is reoriented), read as x to the right, y to the front and z up, as in
# RAS-ordered medical volumes: "front" looks at the data from +y, "top" from +z with the front up.
VIEWS: dict[str, tuple[Vec3, Vec3]] = {
    "front": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "back": ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
    "left": ((-1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "right": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "top": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    "bottom": ((0.0, 0.0, -1.0), (0.0, 1.0, 0.0)),
    "iso": ((1.0, 1.0, 1.0), (0.0, 0.0, 1.0)),
}
VIEW_ALIASES = {"anterior": "front", "posterior": "back", "superior": "top", "inferior": "bottom"}
VIEW_NAMES = (*VIEWS, *VIEW_ALIASES)


# --- helpers ------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=16)
def _view_projection(camera: Camera, aspect: float) -> np.ndarray:
    matrix = camera.projection_matrix(aspect) @ camera.view_matrix()
    matrix.flags.writeable = False
    return matrix


def _check_aspect(aspect: float) -> float:
    aspect = float(aspect)
    if not (math.isfinite(aspect) and aspect > 0.0):
        raise ValueError(f"aspect (width / height) must be positive, got {aspect}")
    return aspect


def _check_size(width: int, height: int) -> tuple[int, int]:
    if int(width) != width or int(height) != height or width < 1 or height < 1:
        raise ValueError(f"image size must be positive integers, got {width} x {height}")
    return int(width), int(height)


def _check_finite(**values: float) -> None:
    for name, value in values.items():
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value}")
