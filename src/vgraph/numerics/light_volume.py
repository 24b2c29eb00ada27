"""Light volume: the transmittance of a directional light at every voxel (Behrens & Ratering 1998;
Ropinski et al. 2008, Inviwo's LightVolume), by a slab sweep in numpy.

Model (the LightVolume processor and the ray casters' shadows rely on it; tests check each rule):

1. Extinction: each voxel's normalised intensity (non-finite voxels as the value range's ends, as
   the texture upload) is classified by the TF's 4096-entry LUT (linear between entries, rule 5 of
   vgraph.numerics.reference_raycast); its alpha ``a`` is the opacity of one sample at rate 1, i.e.
   of ``h = min(spacing)`` world units, so the extinction is ``sigma = -ln(1 - a) / h`` per world
   unit (``a`` at most ``1 - 1e-6``: sigma stays finite, 13.8 / h).
2. Transmittance: ``T(p) = exp(-integral of sigma from p towards the light until the box of voxel
   centres ends)``; outside that box nothing absorbs. A uniform medium gives ``T = exp(-sigma d)``
   with d the distance to the box along the light, exactly (up to float32).
3. Sweep: in the volume's index space (the light turned by the direction matrix), along the axis k
   the light crosses the most voxels per world unit (on a tie z, then y), slice by slice from the
   face the light enters, whose slice has optical depth ``tau = 0``. Between two slices the light
   travels ``l = spacing_k / |light_k|`` world units and moves ``l * light_j / spacing_j`` voxels
   along each other axis j. The slices are taken in chunks of CHUNK_SLICES: on a grid sheared with
   the light (the chunk's first slice, grown on the side the light comes from), each grid point is
   one ray; slice j's intensities are interpolated bilinearly where the rays cross it
   (scipy.ndimage.shift, order 1), classified there (rule 1; 0 beyond the box), and the ray's
   optical depth grows by the trapezoid ``l (sigma_before + sigma_now) / 2``. Slice j's own voxels
   take the optical depth of the rays at their position, interpolated bilinearly; the chunk's last
   slice starts the next chunk, and rays still outside the box start at 0. So the optical depth
   is resampled once per slice on the way out but only once per chunk on the way on: resampling it
   at every slice (the first version, kept as bench/gl_light_sweep.py) blurred the shadows of thin
   structures (an oblique light on the bonsai: |T - T_rays| up to 0.70, mean 0.016 against 0.39
   and 0.007 now). ``T = exp(-tau)``. The optical depth, not T, is interpolated: in a uniform
   medium it is linear in the distance, so the sweep is exact there (the trapezoid too, and for
   layers of whole voxels: m voxels along k absorb ``exp(-sigma m l)``). Elsewhere the errors are
   the trapezoid's over a step of l (the shadow rays integrate with steps of min(spacing) / 4),
   a light entering through a side face between two slices (counted from the slice before, with
   sigma 0 there), and the bilinear resamplings; bench/bench_shadows.py measures them against
   vgraph.numerics.reference_shadows (docs/reports/performance.md, "Volumetric shadows").
4. Storage: 16-bit codes ``round(T * 65535)`` with declared range (0, 65535), on the input's grid,
   so the normalised intensity of the light volume is T within 7.6e-6 and its texture is R16.
5. Gradient classification (the LightVolume's ``gradient_opacity`` and ``transfer_function_2d``,
   linked to the RayCaster's): the alpha of rule 1 becomes that of the ray casters' model
   (vgraph.numerics.reference_classification, rules 2-4: the 2D TF's alpha bilinear at (v, f),
   times the gradient-opacity curve at f), with f each voxel's gradient fraction
   (vgraph.numerics.voxel_gradients.gradient_fractions: the quantised voxel gradient's magnitude
   over the volume's largest, as the GL gradient volume gives it). In the sweep f is interpolated
   with the intensities and classified with them: at the voxels it is the ray casters' f; between
   them it interpolates the magnitudes where the ray casters take the magnitude of the
   interpolated gradient (at most as large). Both off: rule 1, bit for bit.

Memory: up to four float32 copies of the volume (six with rule 5: the gradient fractions and their slices) (the intensities, their slices in sweep order, the
optical depth and its copy in [z, y, x] order) besides the codes, and a few sheared slices.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from vgraph.errors import VGraphError
from vgraph.numerics.reference_classification import bilinear
from vgraph.numerics.reference_raycast import lookup
from vgraph.numerics.voxel_gradients import gradient_fractions
from vgraph.progress import steps
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

MAX_ALPHA = 1.0 - 1e-6  # rule 1: an opaque voxel still has a finite extinction
CODES = 65535  # rule 4
SLAB_VOXELS = 2**22  # classified slab by slab: float64 temporaries of ~100 MB at most
PROGRESS_VOXELS = 32 * 2**20  # show a progress bar above this many voxels, as the gradient volume
CHUNK_SLICES = 64  # slices a sheared grid spans (rule 3): 4 resamplings of the optical depth for 256


class Extinction:
    """sigma per world unit of normalised intensities under ``transfer_function`` (rule 1): the
    LUT's alpha, linear between entries, as the CPU reference ray caster classifies; with a
    ``classification`` (a reference_classification.GradientClassification that is not off) the
    alpha of rule 5 from the intensities and the gradient fractions."""

    def __init__(self, volume: Volume, transfer_function: TransferFunction, classification=None):
        self.alpha = transfer_function.for_volume(volume).lut().astype(np.float64)[:, 3]
        self.entries = np.arange(len(self.alpha), dtype=np.float64)
        self.h = float(min(volume.spacing))
        on = classification is not None and not classification.is_off
        table_2d = classification.transfer_function_2d if on else None
        curve = classification.gradient_opacity if on else None
        # Alpha only: rgb does not absorb (unpremultiplying the table leaves its alpha as it is).
        self.table = None if table_2d is None else table_2d.lut().astype(np.float64)[..., 3:4]
        self.factors = None if curve is None else curve.lut().astype(np.float64)[:, None]

    @property
    def uses_gradients(self) -> bool:
        """Whether the classification reads gradient fractions (rule 5)."""
        return self.table is not None or self.factors is not None

    def __call__(self, values: np.ndarray, fractions: np.ndarray | None = None) -> np.ndarray:
        if self.table is None:
            alpha = np.interp(np.clip(values, 0.0, 1.0) * (len(self.alpha) - 1), self.entries, self.alpha)
        else:
            alpha = bilinear(self.table, values.ravel(), fractions.ravel())[:, 0].reshape(values.shape)
        if self.factors is not None:
            alpha = alpha * lookup(self.factors, fractions.ravel())[:, 0].reshape(values.shape)
        return (-np.log1p(-np.minimum(alpha, MAX_ALPHA)) / self.h).astype(np.float32)


def normalized_values(volume: Volume) -> np.ndarray:
    """float32 [z, y, x] normalised intensities, non-finite voxels as the value range's ends."""
    data = volume.data
    out = np.empty(data.shape, dtype=np.float32)
    rows = max(1, SLAB_VOXELS // (data.shape[1] * data.shape[2]))
    for z0 in range(0, data.shape[0], rows):
        values = data[z0:z0 + rows]
        if volume.nonfinite_count:
            lo, hi = volume.value_range
            values = np.nan_to_num(values.astype(np.float64), nan=lo, posinf=hi, neginf=lo)
        out[z0:z0 + rows] = volume.normalized(values)
    return out


def extinction(volume: Volume, transfer_function: TransferFunction, classification=None) -> np.ndarray:
    """float32 [z, y, x] sigma per world unit at every voxel (rules 1 and 5)."""
    of = Extinction(volume, transfer_function, classification)
    return of(normalized_values(volume), gradient_fractions(volume) if of.uses_gradients else None)


def index_light(volume: Volume, light_direction) -> np.ndarray:
    """The unit direction towards the light along the volume's index axes (x, y, z)."""
    light = np.asarray(light_direction, dtype=np.float64)
    largest = np.abs(light).max() if light.shape == (3,) else 0.0
    if not (np.all(np.isfinite(light)) and largest > 0.0):
        raise VGraphError(f"light volume: the light direction must be 3 finite numbers, not all 0, "
                          f"got {light_direction!r}")
    light = light / largest  # scaled first: |(1e308,)*3| overflows
    if not volume.is_axis_aligned:
        light = np.asarray(volume.direction, dtype=np.float64).T @ light
    return light / np.linalg.norm(light)


@dataclass(frozen=True)
class Sweep:
    """Where the sweep of rule 3 goes: slices along [z, y, x] axis ``axis``, taken from the light
    (``reverse``: from the last slice), ``length`` world units apart along the light, the light
    coming from ``offset`` voxels (rows, columns of a slice) of the previous slice."""

    axis: int
    reverse: bool
    length: float
    offset: tuple[float, float]

    @classmethod
    def of(cls, spacing, light: np.ndarray) -> "Sweep":
        """The sweep for ``spacing`` and ``light`` (unit, towards the light, index axes), (x, y, z)."""
        per_voxel = np.asarray(light, dtype=np.float64) / np.asarray(spacing, dtype=np.float64)
        # The axis the light crosses the most voxels on (x, y, z numbering); on a tie z, then y,
        # whose slices lie contiguous in memory.
        k = 2 - int(np.argmax(np.abs(per_voxel)[::-1]))
        length = 1.0 / abs(per_voxel[k])
        lateral = [j for j in (2, 1, 0) if j != k]  # the slice's (row, column) axes in x, y, z numbering
        return cls(2 - k, bool(per_voxel[k] > 0), length, tuple(length * per_voxel[j] for j in lateral))

    def stack(self, array: np.ndarray) -> np.ndarray:
        """[z, y, x] ``array`` as slices in sweep order (a view)."""
        stack = np.moveaxis(array, self.axis, 0)
        return stack[::-1] if self.reverse else stack

    def unstack(self, stack: np.ndarray) -> np.ndarray:
        """Slices in sweep order back as a [z, y, x] array."""
        return np.ascontiguousarray(np.moveaxis(stack[::-1] if self.reverse else stack, 0, self.axis))


def transmittance(values: np.ndarray, extinction_of, spacing, light: np.ndarray,
                  chunk: int = CHUNK_SLICES, fractions: np.ndarray | None = None) -> np.ndarray:
    """float32 [z, y, x] transmittance T by the sweep of rule 3: ``values`` [z, y, x] normalised
    intensities, ``extinction_of`` their sigma (an Extinction), ``spacing`` and ``light`` (unit,
    towards the light, index axes) as (x, y, z); ``chunk`` slices share one sheared grid;
    ``fractions`` [z, y, x] the voxels' gradient fractions where ``extinction_of`` reads them
    (rule 5), interpolated as the intensities."""
    sweep = Sweep.of(spacing, light)
    # Contiguous slices: strided ones (a sweep along x) made the sweep 8x slower.
    stacks = [np.ascontiguousarray(sweep.stack(a), dtype=np.float32) for a in (values, fractions) if a is not None]
    stack = stacks[0]
    out = np.empty(stack.shape, dtype=np.float32)  # the optical depth first, T at the end
    out[0] = 0.0
    show = stack.size > PROGRESS_VOXELS  # on stderr; the GUI hears every chunk (vgraph.progress)
    for first in steps(range(0, len(stack) - 1, chunk), "light volume", show=show, unit="chunk", file=sys.stderr):
        last = min(first + chunk, len(stack) - 1)
        out[first + 1:last + 1] = chunk_depths([s[first:last + 1] for s in stacks], out[first], extinction_of, sweep)
    np.exp(np.negative(out, out=out), out=out)
    return sweep.unstack(out)


def chunk_depths(slices, depth: np.ndarray, extinction_of, sweep: "Sweep") -> np.ndarray:
    """The optical depths of ``slices[1:]`` (normalised intensities, sweep order) from those of
    ``slices[0]`` (``depth``): along the light's rays on a grid sheared with them (rule 3).
    ``slices`` may be a list of such stacks (the intensities, their gradient fractions), each
    interpolated alike and passed to ``extinction_of`` in that order."""
    channels = slices if isinstance(slices, list) else [slices]
    count, rows, columns = len(channels[0]) - 1, channels[0].shape[1], channels[0].shape[2]
    offset = np.asarray(sweep.offset)
    # A ray through voxel p of slice j crossed the chunk's first slice at p + j * offset: the
    # sheared grid holds those points, so it reaches count * |offset| beyond the slice on that side.
    reach = np.ceil(count * np.abs(offset)).astype(int) + 1
    pad = [(int(r) if o < 0 else 0, int(r) if o > 0 else 0) for r, o in zip(reach, offset)]
    inner = (slice(pad[0][0], pad[0][0] + rows), slice(pad[1][0], pad[1][0] + columns))
    grid = [np.arange(-low, n + high, dtype=np.float64) for (low, high), n in zip(pad, (rows, columns))]

    def sheared(j: int) -> np.ndarray:
        """sigma of slice j where the rays cross it: intensities interpolated, then classified; 0
        outside the box."""
        values = [ndimage.shift(np.pad(c[j], pad, mode="edge"), j * offset, order=1, mode="nearest",
                                prefilter=False) for c in channels]
        source = [axis - j * o for axis, o in zip(grid, offset)]  # where each point lies in slice j
        inside = [(s >= -1e-6) & (s <= n - 1 + 1e-6) for s, n in zip(source, (rows, columns))]
        return np.where(inside[0][:, None] & inside[1][None, :], extinction_of(*values), np.float32(0.0))

    along = np.pad(depth, pad)  # optical depth of each ray so far; 0 for rays still outside the box
    before = sheared(0)
    half_step = np.float32(0.5 * sweep.length)
    out = np.empty((count, rows, columns), dtype=np.float32)
    for j in range(1, count + 1):
        now = sheared(j)
        along += half_step * (before + now)
        out[j - 1] = ndimage.shift(along, -j * offset, order=1, mode="constant", cval=0.0,
                                   prefilter=False)[inner]
        before = now
    return out


def light_volume(volume: Volume, transfer_function: TransferFunction, light_direction,
                 classification=None) -> Volume:
    """The light volume of ``volume`` under ``transfer_function`` lit from ``light_direction``
    (world, towards the light): 16-bit transmittance codes on the volume's grid (rule 4).
    ``classification``: a reference_classification.GradientClassification (gradient opacity, a 2D
    TF) classifying the voxels as the ray casters do (rule 5); None or off: the TF's alpha alone."""
    light = index_light(volume, light_direction)
    extinction_of = Extinction(volume, transfer_function, classification)
    fractions = gradient_fractions(volume) if extinction_of.uses_gradients else None
    t = transmittance(normalized_values(volume), extinction_of, volume.spacing, light, fractions=fractions)
    codes = np.rint(np.clip(t, 0.0, 1.0) * CODES).astype(np.uint16)
    source = f"light volume of {volume.source}" if volume.source else "light volume"
    return Volume(codes, spacing=volume.spacing, origin=volume.origin, direction=volume.direction,
                  declared_range=(0.0, float(CODES)), source=source)
