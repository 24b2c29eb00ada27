"""GL helpers shared by the volume renderers (EntryExitPoints, RayCaster and later ray casters).

Conventions (docs/rendering.md explains them for users):

- Texture space: voxel i along an axis has its centre at texture coordinate (i + 0.5) / dims, where
  GL samples a 3D texture. A world point p maps to ``t = ((p - origin) / spacing + 0.5) / dims``
  and back to ``p = origin + (t * dims - 0.5) * spacing`` (VolumeGeometry).
- The volume's box is the box spanned by the voxel centres, ``[origin, origin + (dims - 1) *
  spacing]`` (the CPU reference's box), in texture space ``[0.5 / dims, 1 - 0.5 / dims]``. Rays
  are intersected with it grown by ``BOX_EPSILON * (max |corner| + min spacing)`` on every side
  (so rays grazing a face count as hits, as in the reference) and the stored coordinates are
  clamped back into it. EntryExitPoints rasterises a box grown by PROXY_MARGIN of its size only to
  find the pixels to compute; each fragment intersects its own ray with the box exactly.
- Entry and exit images are RGBA32F at the render size: rgb = texture coordinates of the first and
  last point of the pixel's ray inside the box and between the near and far planes; alpha = 1 where
  the ray meets that part of the box, 0 (and rgb 0) elsewhere.
- Camera planes: the pixel centre (ndc_x, ndc_y) lies on the near plane at ``centre + ndc_x * right
  + ndc_y * up`` (``plane_frame``), the origin of ``Camera.rays``; likewise on the far plane.
- Sampling: ray casters sample through a sampler object with linear filtering and clamp-to-edge (the
  volume's own texture keeps its state). uint8 volumes are sampled from an R16 copy holding value *
  257, which is the same normalised value: llvmpipe filters 8-bit textures with 8-bit weights (errors
  up to 0.007 of the range) but 16-bit and float textures with float weights (~1e-7), and R16 is also
  the fastest format there.
- Empty-space skipping works on blocks of ``BLOCK``^3 voxels: block b (per axis) holds the samples
  whose voxel coordinate u = t * dims - 0.5 has floor(u) in [b * BLOCK, (b + 1) * BLOCK); its range
  is the min and max normalised intensity over voxels [b * BLOCK - 1, (b + 1) * BLOCK + 1], which
  covers every voxel such a sample's trilinear (or nearest) reconstruction can touch, with one voxel
  to spare for rounding. A block is occupied when some intensity in its range can contribute (TF
  opacity > 0, or reaching the iso level); empty blocks store their chessboard distance to the
  nearest occupied block, so a ray can jump over whole empty regions (skip_radii).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import moderngl
import numpy as np
from scipy import ndimage

from vgraph.camera import Camera
from vgraph.errors import VGraphError
from vgraph.gl.context import bind_default_framebuffer
from vgraph.image import Image
from vgraph.implicit import UNIT_BOX
from vgraph.numerics.reference_raycast import GRADIENT_EPSILON
from vgraph.transfer_function import LUT_SIZE, TransferFunction
from vgraph.volume import Volume

BOX_EPSILON = 1e-5  # relative growth of the rasterised box (float32 version of the reference's)
PROXY_MARGIN = 0.01  # relative growth of the box EntryExitPoints rasterises (coverage only)
BLOCK = 8  # voxels per empty-space block along each axis
MIN_EMPTY_FRACTION = 0.1  # below this share of empty blocks, skipping costs more than it saves

# A view of the implicit functions' box [-1, 1]^3 (where the FunctionSelector puts its volumes).
# It frames whatever volume arrives (fit_to_data) with automatic near/far planes.
DEFAULT_CAMERA = Camera(**{**Camera.looking_at_box(*UNIT_BOX, direction=(-0.45, -0.35, -1.0)).model_dump(),
                           "near": None, "far": None, "fit_to_data": True})


def view_camera(camera: Camera, volume: Volume, size) -> Camera:
    """The concrete camera that renders ``volume`` at ``size`` (Camera.resolved on its box): every
    processor of one view resolves the same camera, so entry points and ray casters agree."""
    return camera.resolved(*VolumeGeometry.of(volume).box, size[0] / size[1])


# --- geometry -------------------------------------------------------------------------------------
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
    return centre, half_height * aspect * right, half_height * true_up


def plane_cuts_box(camera: Camera, plane: str, box_min, box_max) -> bool:
    """Whether the near or far plane passes through the box (only then does it cap any ray)."""
    corners = np.array([[(box_min, box_max)[(i >> axis) & 1][axis] for axis in range(3)] for i in range(8)])
    depths = (corners - np.asarray(camera.position)) @ camera.basis()[2]
    plane_depth = camera.near if plane == "near" else camera.far
    return bool(depths.min() < plane_depth < depths.max())


def ray_uniforms(camera: Camera, size) -> dict[str, tuple[float, ...]]:
    """Uniforms of the pixel rays (Camera.rays): origin near_centre + x near_right + y near_up and
    direction direction_centre + x direction_right + y direction_up (not normalised) for the pixel
    centre at NDC (x, y). Directions are given on their own, not as origin - eye, which would lose
    digits in float32 when the near plane is close to the eye."""
    near = plane_frame(camera, size, "near")
    forward = camera.basis()[2]
    if camera.projection == "perspective":  # through the near-plane point, from the eye
        directions = (forward, near[1] / camera.near, near[2] / camera.near)
    else:
        directions = (forward, np.zeros(3), np.zeros(3))
    names = ("near_centre", "near_right", "near_up", "direction_centre", "direction_right",
             "direction_up")
    return {name: vec(value) for name, value in zip(names, (*near, *directions))}


def linear_sampler(ctx: moderngl.Context):
    """A sampler object with linear filtering and clamp-to-edge (one per context)."""
    sampler = _samplers.get(ctx)
    if sampler is None or isinstance(sampler.mglo, moderngl.InvalidObject):
        sampler = _samplers[ctx] = ctx.sampler(repeat_x=False, repeat_y=False, repeat_z=False,
                                               filter=(moderngl.LINEAR, moderngl.LINEAR))
    return sampler


_samplers: "weakref.WeakKeyDictionary[moderngl.Context, object]" = weakref.WeakKeyDictionary()


class TransferFunctionTexture:
    """The TF's 4096-entry LUT for a volume (TransferFunction.for_volume: TFs in data units or
    percentiles land on the volume's value range) as a 4096 x 1 RGBA32F texture with linear
    filtering, rewritten only when the resolved TF changes. Entry i sits at texture coordinate (i + 0.5) / 4096, so intensity v is
    looked up at v * 4095 / 4096 + 0.5 / 4096 (clamp-to-edge clamps v to [0, 1])."""

    def __init__(self):
        self.texture = None
        self.transfer_function: TransferFunction | None = None
        self.alpha: np.ndarray | None = None

    def update(self, ctx: moderngl.Context, transfer_function: TransferFunction, volume: Volume):
        transfer_function = transfer_function.for_volume(volume)
        if self.texture is None or self.texture.ctx is not ctx:
            self.texture = ctx.texture((LUT_SIZE, 1), 4, dtype="f4")
            self.texture.repeat_x = self.texture.repeat_y = False
            self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.transfer_function = None
        if transfer_function != self.transfer_function:
            lut = transfer_function.lut()
            self.texture.write(np.ascontiguousarray(lut).tobytes())
            self.transfer_function, self.alpha = transfer_function, lut[:, 3].copy()
        return self.texture


# --- empty-space skipping -------------------------------------------------------------------------
_block_ranges: "weakref.WeakKeyDictionary[Volume, tuple]" = weakref.WeakKeyDictionary()


def block_ranges(volume: Volume) -> tuple[np.ndarray, np.ndarray]:
    """(min, max) normalised intensity per block, float32 arrays [bz, by, bx] (module docstring),
    computed once per volume. Non-finite voxels count as the texture upload stores them."""
    cached = _block_ranges.get(volume)
    if cached is None:
        data = volume.data
        if volume.nonfinite_count:
            lo, hi = volume.value_range
            data = np.nan_to_num(data, nan=lo, posinf=hi, neginf=lo)  # a copy, same dtype
        low, high = data, data
        for axis in range(3):
            low = _window_reduce(low, axis, np.minimum)
            high = _window_reduce(high, axis, np.maximum)
        cached = (volume.normalized(low).astype(np.float32), volume.normalized(high).astype(np.float32))
        _block_ranges[volume] = cached
    return cached


def _window_reduce(array: np.ndarray, axis: int, reducer) -> np.ndarray:
    """Reduce ``axis`` to blocks: block b covers indices [b*BLOCK - 1, (b+1)*BLOCK + 1], clamped
    (clamp-to-edge adds nothing new). Works on views, so a large volume is not copied."""
    moved = np.moveaxis(array, axis, 0)
    n = moved.shape[0]
    blocks = -(-n // BLOCK)
    parts = [reducer.reduce(moved[max(b * BLOCK - 1, 0):min((b + 1) * BLOCK + 2, n)], axis=0)
             for b in range(blocks)]
    return np.moveaxis(np.stack(parts), 0, axis)


def occupied_blocks(block_min: np.ndarray, block_max: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """True for blocks where some intensity in the block's range has LUT opacity > 0 (the LUT entry
    range is widened by one entry on each side for the texture filter's rounding)."""
    last = len(alpha) - 1
    lo = np.clip(np.floor(np.clip(block_min, 0.0, 1.0) * last).astype(np.int64) - 1, 0, last)
    hi = np.clip(np.ceil(np.clip(block_max, 0.0, 1.0) * last).astype(np.int64) + 1, 0, last)
    count = np.concatenate([[0], np.cumsum(alpha > 0.0)])
    return count[hi + 1] - count[lo] > 0


def skip_radii(occupied: np.ndarray) -> np.ndarray:
    """float32 per block: 0 where occupied, else k >= 1 such that all blocks within Chebyshev
    distance k - 1 are empty (k = the chessboard distance to the nearest occupied block; the
    whole grid's size where none is occupied)."""
    if occupied.all():
        return np.zeros(occupied.shape, dtype=np.float32)
    if not occupied.any():
        return np.full(occupied.shape, float(max(occupied.shape)), dtype=np.float32)
    return ndimage.distance_transform_cdt(~occupied, metric="chessboard").astype(np.float32)


def radii_if_worthwhile(occupied: np.ndarray) -> np.ndarray | None:
    """skip_radii, or None when under MIN_EMPTY_FRACTION of the blocks are empty: every sample would
    pay for the block look-up and hardly any would be saved."""
    return skip_radii(occupied) if 1.0 - occupied.mean() >= MIN_EMPTY_FRACTION else None


class SkipBlocks:
    """The R32F texture of per-block values for SKIP_EMPTY_SPACE (shaders/raycasting/empty_space.glsl),
    rebuilt only when the volume or what the values depend on changes. For B-spline coefficients
    the block ranges bound the spline too: it is a convex combination of its 4^3 coefficients
    (weights >= 0, summing to 1), which the ranges' one-voxel margin just covers; where float
    rounding puts a sample in the neighbouring block, the coefficient outside the margin has
    weight ~1e-19."""

    def __init__(self):
        self._texture = None
        self._key = None
        self._values_exist = False

    def texture(self, ctx: moderngl.Context, volume: Volume, depends, values):
        """``values(block_min, block_max)`` -> float array per block (skip radii, or the maxima for
        MIP), or None when skipping does not pay; ``depends`` is what ``values`` depends on.
        Returns the texture, or None."""
        key = (ctx, volume, depends)
        if self._key is None or not all(a is b or a == b for a, b in zip(key, self._key)):
            self._key = key
            block_values = values(*block_ranges(volume))
            self._values_exist = block_values is not None
            if self._values_exist:
                self._upload(ctx, block_values)
        return self._texture if self._values_exist else None

    def _upload(self, ctx: moderngl.Context, values: np.ndarray) -> None:
        size = values.shape[::-1]
        if self._texture is None or self._texture.ctx is not ctx or self._texture.size != size:
            if self._texture is not None and self._texture.ctx is ctx:
                self._texture.release()
            self._texture = ctx.texture3d(size, 1, dtype="f4")
        self._texture.write(np.ascontiguousarray(values, dtype=np.float32).tobytes())


def block_grid_uniforms(volume: Volume) -> dict[str, object]:
    """Texture coordinates -> block coordinates q = t * scale + offset (floor(q) = block index)."""
    dims = np.array(volume.dims, dtype=np.float64)
    return {"block_scale": tuple(dims / BLOCK), "block_offset": (-0.5 / BLOCK,) * 3,
            "block_count": tuple(int(-(-d // BLOCK)) for d in volume.dims)}


# --- output images --------------------------------------------------------------------------------
class RenderTargets:
    """Output images kept across evaluations (rewritten in place while the size stays the same) and
    one framebuffer with all of them attached, for shaders with several outputs."""

    def __init__(self, count: int):
        self.count = count
        self.images: list[Image] = []
        self.framebuffer = None

    def ensure(self, ctx: moderngl.Context, size) -> list[Image]:
        size = tuple(int(v) for v in size)
        live = all(image.texture is not None and image.ctx is ctx for image in self.images)
        if not (self.images and live and self.images[0].size == size):
            if live:
                self.release()
            # (Objects of a replaced context went with it and must not be released again.)
            self.images, self.framebuffer = [], None
            self.images = [Image.empty(ctx, size) for _ in range(self.count)]
            self.framebuffer = ctx.framebuffer(color_attachments=[i.texture for i in self.images])
        return self.images

    @property
    def size(self) -> tuple[int, int]:
        return self.images[0].size

    def release(self) -> None:
        for image in self.images:
            if image.texture is not None:
                image.release()
        if self.framebuffer is not None:
            bind_default_framebuffer(self.framebuffer.ctx)
            self.framebuffer.release()
        self.images, self.framebuffer = [], None


def vec(values) -> tuple[float, ...]:
    """A uniform value from a numpy vector (float64 -> Python floats; the GL side is float32)."""
    return tuple(float(v) for v in values)


# --- what a ray caster should show -----------------------------------------------------------------
def visible_under(volume: Volume, transfer_function, bins: int = 256) -> str | None:
    """Which share of the voxels the transfer function gives any opacity (bins of the histogram
    against the LUT's largest opacity in each bin), in words; None if none."""
    counts, _ = volume.histogram(bins)
    alpha = transfer_function.for_volume(volume).lut()[:, 3]
    bin_alpha = alpha[:len(alpha) // bins * bins].reshape(bins, -1).max(axis=1)
    share = counts[bin_alpha > 0].sum() / max(counts.sum(), 1)
    return f"{share:.0%} of the voxels are visible under the transfer function" if share > 0 else None


def crossed_by(volume: Volume, level: float) -> str | None:
    """Whether the volume's values cross the normalised ``level`` (an iso-surface exists)."""
    low, high = block_ranges(volume)
    return f"the volume's values cross the iso level {level:g}" if low.min() < level < high.max() else None


# --- Blinn-Phong lighting, shared by every ray caster ---------------------------------------------
def lighting_properties():
    """The light's property declarations, unpacked into a ray caster's class body:
    ``light, light_direction, ambient, diffuse, specular, shininess = lighting_properties()``.
    Each class gets its own Property objects, in the place it unpacks them."""
    from vgraph.properties import FloatProperty, Invalidation, OptionProperty, VectorProperty
    return (OptionProperty("headlight", choices=["headlight", "direction"],
                           invalidates=Invalidation.RESOURCES,
                           doc="headlight: light from the viewer; direction: light_direction"),
            VectorProperty((1.0, 1.0, 1.0), doc="world-space direction towards the light"),
            FloatProperty(0.3, min=0.0, max=1.0), FloatProperty(0.7, min=0.0, max=1.0),
            FloatProperty(0.2, min=0.0, max=1.0), FloatProperty(32.0, min=1.0, max=512.0))


def shading_uniforms(owner, min_spacing: float) -> dict[str, object]:
    """Uniforms of raycasting/shading.glsl from ``owner``'s lighting properties; gradients at or
    below GRADIENT_EPSILON / min(spacing) leave a sample unshaded, as in the CPU reference."""
    light = np.asarray(owner.light_direction, dtype=np.float64)
    largest = np.abs(light).max()
    if owner.light == "direction" and not largest > 0.0:
        raise VGraphError(f"{owner.id}.light_direction must not be zero, got {list(light)}")
    light = light / largest if largest > 0.0 else light  # scaled first: |(1e308,)*3| overflows
    return {"gradient_epsilon": GRADIENT_EPSILON / min_spacing,
            "light_direction": tuple(float(v) for v in light / max(np.linalg.norm(light), 1e-300)),
            "ambient": owner.ambient, "diffuse": owner.diffuse, "specular": owner.specular,
            "shininess": owner.shininess}

