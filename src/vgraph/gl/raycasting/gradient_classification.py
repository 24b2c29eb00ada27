"""Classification by value and gradient magnitude (a ray-caster component, vgraph.gl.raycasting.
raycaster_base): ``gradient_opacity`` (vgraph.gradient_opacity), a curve over the gradient fraction
multiplying the TF's opacity, and ``transfer_function_2d`` (vgraph.transfer_function_2d, Kniss et
al. 2002), which replaces the 1D TF. Both off (None) by default: then it binds nothing and the
shader compiles the plain classification, so images are what they were bit for bit.

The model is the CPU reference's (vgraph.numerics.reference_classification): the gradient is read
from the precomputed gradient volume (vgraph.gl.raycasting.gradient_volume; built once per volume,
shading or not), its magnitude divided by the volume's largest voxel gradient magnitude
(``largest_magnitude``, derived data kept per volume). The curve is a 1024 x 1 LUT texture, the 2D
TF a 256 x 256 RGBA32F texture, both with linear filtering (shaders/raycasting/
gradient_classification.glsl). Only the compositing modes given (the RayCaster: dvr and
first_hit) classify samples; in another mode (mip, iso, xray classify one value per ray, which has
no gradient) either property is refused by name.
"""

from __future__ import annotations

import sys

import moderngl
import numpy as np
from tqdm import tqdm

from vgraph import derived
from vgraph.errors import VGraphError
from vgraph.gl.raycasting.gradient_volume import SLAB_VOXELS, gradient_texture
from vgraph.gl.raycasting.raycaster_base import Binding, Component, Frame
from vgraph.gl.raycasting.textures import LookupTexture, linear_sampler
from vgraph.numerics.voxel_gradients import slab_gradients
from vgraph.gradient_opacity import LUT_SIZE as CURVE_SIZE
from vgraph.gl.raycasting.geometry import vec
from vgraph.properties import GradientOpacityProperty, TransferFunction2DProperty
from vgraph.transfer_function_2d import LUT_SIZE as TABLE_SIZE, TransferFunction2D
from vgraph.volume import Volume

LARGEST = "largest gradient magnitude"  # the kinds of derived data (vgraph.derived) this module makes
HISTOGRAM = "value gradient histogram"
HISTOGRAM_BINS = 128  # per axis of the 2D TF editor's histogram
PROGRESS_SLABS = 8  # a store read in this many slabs or more shows a progress bar


def largest_magnitude(volume: Volume) -> float:
    """The largest magnitude of the volume's voxel gradients (unquantised central differences of
    the normalised intensities, per world unit), slab by slab; cached per volume. A store over its
    memory budget is read brick by brick from level 0, one slab at a time with its one-slice halo
    (the same voxels and arithmetic as in memory, so the same number bit for bit); only the
    running largest is kept, with a progress bar when the store takes many slabs."""
    def compute() -> float:
        rows = store_rows(volume)
        nz, ny, nx = volume.shape if rows is not None else volume.data.shape
        thickness = max(1, SLAB_VOXELS // (nx * ny))
        slabs = range(0, nz, thickness)
        largest = 0.0
        for z0 in tqdm(slabs, desc="largest gradient", unit="slab", file=sys.stderr, leave=False,
                       disable=rows is None or len(slabs) < PROGRESS_SLABS):
            gradients = slab_gradients(volume, z0, min(z0 + thickness, nz), rows)
            largest = max(largest, float(np.sqrt((gradients ** 2).sum(axis=-1)).max()))
        return largest
    return derived.value(volume, LARGEST, compute)


def store_rows(volume: Volume):
    """A reader of level-0 slices [a, b) of a store over its memory budget; None for a volume
    whose array is (or may be) in memory."""
    bricks = getattr(volume, "bricks", None)
    if bricks is None or volume.fits_budget:
        return None
    _, ny, nx = volume.shape
    return lambda a, b: bricks.read(0, (a, 0, 0), (b, ny, nx))


def value_gradient_histogram(volume: Volume, bins: int = 128) -> np.ndarray:
    """(bins, bins) voxel counts over the 2D TF's plane, [gradient, value]: each voxel's normalised
    intensity and gradient fraction (its central-difference gradient over ``largest_magnitude``),
    slab by slab; what a 2D TF editor draws its primitives over (Kniss et al. 2002, fig. 3)."""
    nz, ny, nx = volume.data.shape
    thickness = max(1, SLAB_VOXELS // (nx * ny))
    largest = largest_magnitude(volume)
    counts = np.zeros((bins, bins), dtype=np.int64)
    for z0 in range(0, nz, thickness):
        z1 = min(z0 + thickness, nz)
        magnitude = np.sqrt((slab_gradients(volume, z0, z1) ** 2).sum(axis=-1))
        fraction = magnitude / largest if largest > 0.0 else magnitude
        values = volume.normalized(np.asarray(volume.data[z0:z1], dtype=np.float64))
        finite = np.isfinite(values)
        counts += np.histogram2d(np.clip(fraction[finite], 0.0, 1.0), np.clip(values[finite], 0.0, 1.0),
                                 bins=bins, range=((0.0, 1.0), (0.0, 1.0)))[0].astype(np.int64)
    return counts


def editor_histogram(volume: Volume) -> np.ndarray | None:
    """value_gradient_histogram with HISTOGRAM_BINS bins, kept per volume; None for a volume
    drawn brick by brick (its whole array is what the bricks avoid reading)."""
    if volume.bricks is not None and not getattr(volume, "fits_budget", True):
        return None
    return derived.value(volume, HISTOGRAM, lambda: value_gradient_histogram(volume, HISTOGRAM_BINS))


class TableTexture:
    """A 2D TF's (n, n, 4) table as an n x n RGBA32F texture, linear filter, clamp-to-edge;
    rewritten only when the TF changes."""

    def __init__(self):
        self.texture = None
        self.key = None
        self.alpha_by_value: np.ndarray | None = None  # max alpha over the gradient axis, per value

    def update(self, ctx: moderngl.Context, transfer_function: TransferFunction2D):
        if self.texture is None or self.texture.ctx is not ctx:
            self.texture = ctx.texture((TABLE_SIZE, TABLE_SIZE), 4, dtype="f4")
            self.texture.repeat_x = self.texture.repeat_y = False
            self.texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.key = None
        if transfer_function != self.key:
            table = transfer_function.lut(TABLE_SIZE)
            self.texture.write(np.ascontiguousarray(table).tobytes())
            self.alpha_by_value = table[..., 3].max(axis=0)
            self.key = transfer_function
        return self.texture


class GradientClassification(Component):
    """gradient_opacity and transfer_function_2d (module docstring); classifies in the modes
    ``modes`` of the processor's option ``mode`` (always with ``mode=None``: the
    CurvatureVolumeRaycaster, which composites as dvr)."""

    glsl = ("raycasting/gradient_classification.glsl",)

    def __init__(self, mode: str | None = "compositing", modes: tuple[str, ...] = ("dvr", "first_hit"),
                 from_samples: bool = False):
        # from_samples (the bricks, which have no gradient volume): the gradient as central
        # differences of the sampled intensity (CLASSIFICATION_CENTRAL; the shader says why equal)
        self.mode, self.modes, self.from_samples = mode, modes, from_samples

    def start(self) -> None:
        self.curve = LookupTexture(CURVE_SIZE)
        self.table = TableTexture()

    def declare(self):
        return {"gradient_opacity": GradientOpacityProperty(
                    None, doc="opacity factor over the gradient fraction (|gradient| / the volume's "
                              "largest), multiplying the TF's alpha; a preset name "
                              "(boundaries, strong-edges); null: off"),
                "transfer_function_2d": TransferFunction2DProperty(
                    None, doc="RGBA over (value, gradient fraction) from rectangles, triangles and "
                              "Gaussians, replacing transfer_function; a preset name "
                              "(boundaries, two-materials); null: off")}

    def is_on(self) -> bool:
        processor = self.processor
        return processor.gradient_opacity is not None or processor.transfer_function_2d is not None

    def check(self) -> None:
        """Refuses gradient classification in a mode that classifies no samples, by name."""
        processor = self.processor
        mode = getattr(processor, self.mode) if self.mode is not None else None
        if self.is_on() and self.mode is not None and mode not in self.modes:
            name = "gradient_opacity" if processor.gradient_opacity is not None else "transfer_function_2d"
            raise VGraphError(f"{processor.id}.{name}: classifies samples by their gradient, which "
                              f"{self.mode} {mode} does not take (it classifies one value per ray); "
                              f"use {' or '.join(self.modes)}, or set {processor.id}.{name} to null")

    def opacity_by_value(self, ctx: moderngl.Context) -> np.ndarray | None:
        """With a 2D TF, its largest alpha per value (over the gradient axis) for empty-space
        skipping: a 1D alpha table whose linear interpolation bounds the 2D TF's bilinear one (a
        block whose values have none of it is empty at every gradient); else None. Gradient
        opacity only lowers the TF's alpha, so the TF's own table still bounds it."""
        transfer_function = self.processor.transfer_function_2d
        if transfer_function is None:
            return None
        self.table.update(ctx, transfer_function)
        return self.table.alpha_by_value

    def bind(self, frame: Frame) -> Binding:
        if not self.is_on():
            return Binding()
        self.check()
        if self.from_samples:
            return self._bind_from_samples(frame)
        gradients, scale = gradient_texture(frame.ctx, frame.volume)
        largest = largest_magnitude(frame.volume)
        binding = Binding(textures={"classification_gradients": gradients},
                          samplers={"classification_gradients": linear_sampler(frame.ctx)},
                          uniforms={"classification_gradient_scale": vec(scale),
                                    "inverse_largest_gradient": 1.0 / largest if largest > 0.0 else 0.0})
        self._bind_tables(frame, binding)
        return binding

    def _bind_from_samples(self, frame: Frame) -> Binding:
        """Brick by brick: the gradient from central differences at the sample over the volume's
        largest voxel gradient (``largest_magnitude``: a store's by one pass over its level 0);
        the curve and the 2D table bound as for the gradient volume."""
        largest = largest_magnitude(frame.volume)
        binding = Binding(defines={"CLASSIFICATION_CENTRAL": True},
                          uniforms={"inverse_largest_gradient": 1.0 / largest if largest > 0.0 else 0.0,
                                    "classification_voxel_step": vec(1.0 / frame.geometry.dims),
                                    "classification_inverse_span": vec(0.5 / frame.geometry.spacing)})
        self._bind_tables(frame, binding)
        return binding

    def _bind_tables(self, frame: Frame, binding: Binding) -> None:
        """The gradient-opacity curve and the 2D TF's table, where set."""
        processor = self.processor
        if processor.gradient_opacity is not None:
            curve = processor.gradient_opacity
            binding.defines["GRADIENT_OPACITY"] = True
            binding.textures["gradient_opacity"] = self.curve.update(
                frame.ctx, curve, lambda: np.repeat(curve.lut(CURVE_SIZE)[:, None], 4, axis=1))
        if processor.transfer_function_2d is not None:
            binding.defines["TRANSFER_FUNCTION_2D"] = True
            binding.textures["transfer_function_2d"] = self.table.update(frame.ctx, processor.transfer_function_2d)
