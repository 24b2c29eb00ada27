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
   the light crosses the most voxels per world unit, slice by slice from the face the light enters:
   that slice has optical depth ``tau = 0``; each further slice ``tau = tau_up + l (sigma +
   sigma_up) / 2`` with ``l = spacing_k / |light_k|`` the world length between two slices along the
   light and ``tau_up``, ``sigma_up`` the previous slice's values at the point the light comes from
   (the voxel moved by ``l * light_j / spacing_j`` voxels along the other two axes), interpolated
   bilinearly (scipy.ndimage.shift, order 1). Where that point lies beyond the slice's edges, the
   light enters through a side face at ``d < l`` from the voxel: ``tau = sigma d``. Then ``T =
   exp(-tau)``. The optical depth, not T, is interpolated: in a uniform medium it is linear in
   the distance, so the sweep is exact there (T is not: interpolating it was off by 0.2 near the
   side faces of an oblique light). The trapezoid is exact for a uniform medium and for layers
   of whole voxels (a layer of m voxels along k absorbs ``exp(-sigma m l)``); elsewhere the
   errors are those of classifying voxels before interpolating and of the bilinear resampling
   (docs/reports/accuracy.md's shadow rows against vgraph.numerics.reference_shadows).
4. Storage: 16-bit codes ``round(T * 65535)`` with declared range (0, 65535), on the input's grid,
   so the normalised intensity of the light volume is T within 7.6e-6 and its texture is R16.

Memory: three float32 copies of the volume (sigma, its slices in sweep order, T) besides the codes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from vgraph.errors import VGraphError
from vgraph.numerics.reference_raycast import lookup
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

MAX_ALPHA = 1.0 - 1e-6  # rule 1: an opaque voxel still has a finite extinction
CODES = 65535  # rule 4
SLAB_VOXELS = 2**22  # classified slab by slab: float64 temporaries of ~100 MB at most


def extinction(volume: Volume, transfer_function: TransferFunction) -> np.ndarray:
    """float32 [z, y, x] sigma per world unit of every voxel (rule 1)."""
    lut_alpha = transfer_function.for_volume(volume).lut().astype(np.float64)[:, 3:4]
    h = float(min(volume.spacing))
    data = volume.data
    out = np.empty(data.shape, dtype=np.float32)
    rows = max(1, SLAB_VOXELS // (data.shape[1] * data.shape[2]))
    for z0 in range(0, data.shape[0], rows):
        values = data[z0:z0 + rows]
        if volume.nonfinite_count:
            lo, hi = volume.value_range
            values = np.nan_to_num(values.astype(np.float64), nan=lo, posinf=hi, neginf=lo)
        alpha = lookup(lut_alpha, volume.normalized(values).ravel())[:, 0]
        out[z0:z0 + rows] = (-np.log1p(-np.minimum(alpha, MAX_ALPHA)) / h).reshape(values.shape)
    return out


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


def transmittance(sigma: np.ndarray, spacing, light: np.ndarray) -> np.ndarray:
    """float32 [z, y, x] transmittance T by the sweep of rule 3; ``sigma`` [z, y, x] per world
    unit, ``spacing`` and ``light`` (unit, towards the light, index axes) as (x, y, z)."""
    sweep = Sweep.of(spacing, light)
    # Contiguous slices: a strided one (a sweep along x) made the sweep 8x slower.
    stack, length = np.ascontiguousarray(sweep.stack(sigma)), sweep.length
    shift = [-o for o in sweep.offset]  # ndimage.shift moves content by +shift: out[i] = in[i - shift]
    side = side_distance(stack.shape[1:], sweep.offset, length)
    from_side = side < length  # the light comes in through a side face within one slice step
    out = np.empty(stack.shape, dtype=np.float32)  # the optical depth first, T at the end
    out[0] = 0.0
    sigma_up = np.empty(stack.shape[1:], dtype=np.float32)
    side_length = side[from_side].astype(np.float32)
    for n in range(1, len(stack)):
        ndimage.shift(out[n - 1], shift, output=out[n], order=1, mode="constant", cval=0.0, prefilter=False)
        ndimage.shift(stack[n - 1], shift, output=sigma_up, order=1, mode="constant", cval=0.0, prefilter=False)
        sigma_up += stack[n]
        sigma_up *= np.float32(0.5 * length)
        out[n] += sigma_up
        out[n][from_side] = side_length * stack[n][from_side]
    np.exp(np.negative(out, out=out), out=out)
    return sweep.unstack(out)


def side_distance(shape, offset, length: float) -> np.ndarray:
    """World distance along the light from each pixel of a slice ``shape`` (rows, columns) to the
    slice's side faces (rule 3), where the light moves ``offset`` voxels (rows, columns) per
    slice step of ``length``; infinite along an axis the light does not move on."""
    distance = np.full(shape, np.inf)
    for axis, (size, move) in enumerate(zip(shape, offset)):
        if move == 0.0:
            continue
        index = np.arange(size, dtype=np.float64)
        steps = (size - 1 - index) / move if move > 0 else index / -move
        distance = np.minimum(distance, np.expand_dims(steps * length, 1 - axis))
    return distance


def light_volume(volume: Volume, transfer_function: TransferFunction, light_direction) -> Volume:
    """The light volume of ``volume`` under ``transfer_function`` lit from ``light_direction``
    (world, towards the light): 16-bit transmittance codes on the volume's grid (rule 4)."""
    light = index_light(volume, light_direction)
    t = transmittance(extinction(volume, transfer_function), volume.spacing, light)
    codes = np.rint(np.clip(t, 0.0, 1.0) * CODES).astype(np.uint16)
    source = f"light volume of {volume.source}" if volume.source else "light volume"
    return Volume(codes, spacing=volume.spacing, origin=volume.origin, direction=volume.direction,
                  declared_range=(0.0, float(CODES)), source=source)
