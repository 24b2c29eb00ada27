"""The Volume data type: a [z, y, x] array with its place in the world and its value range.

Conventions (docs/guide/volumes.md says the same for users):
- ``data`` is indexed [z, y, x]; x varies fastest in memory, as in raw files and GL 3D textures.
- ``spacing`` and ``origin`` are (x, y, z) in world units, ``direction`` the 3x3 direction
  cosines (rows of the matrix; column c is the world direction of index axis c). Voxel (i, j, k) =
  data[k, j, i] has its centre at origin + direction @ ((i, j, k) * spacing) in patient space, RAS
  (``affine``; docs/explanations/conventions.md). Readers convert what the file declares into it.
- ``value_range`` maps stored values to normalised intensities in [0, 1], the unit of every
  transfer-function position and iso level: the ``declared_range`` (stated by the file or the user)
  if any, else [min, max] of the finite values for EVERY dtype. A type's full scale is not a value
  range: 12-bit scans stored as uint16 over [0, 65535] rendered black. A constant volume still
  gets a usable range [v, v + max(1, |v| 1e-6)].
- ``percentiles(percents)`` gives data values at percentiles of the finite voxels (for transfer
  functions placed in percent and the robust window), from one cached pass over the data.
- ``time_steps`` is the number of time points of the file the volume is one time point of.
- ``holds_labels``: the file declares that the voxels are labels (a label-map intent or group),
  not intensities.
- Textures hold the stored values (R16 normalised for 8 and 16 bit, R32F otherwise) unless float32
  cannot carry them: values beyond +-1e30 (float64 data up to 1.8e308, float32 near its limit) or
  a range narrower than 1e-30 (subnormal data). Those volumes are uploaded as normalised
  intensities computed in float64, and ``texture_scale_offset()`` says so with (1, 0).
- ``at_precision("16bit")`` is the volume as 16-bit codes over its value range, q = round(65535 *
  normalised intensity), sampled from an R16 texture (llvmpipe's fastest format): normalised
  intensities within 0.5 / 65535 (7.6e-6) of the stored values', values outside the value range
  clamped to its ends. It is made once per volume and has its own textures, so a volume drawn at
  both precisions keeps both. 8- and 16-bit volumes are their own 16-bit copy.
- A volume wider than the GL's 3D texture limit on any axis is refused when it is uploaded, naming
  the limit; the RayCaster does not upload such volumes but draws them brick by brick.
- A volume of cubic B-spline coefficients (``is_spline_coefficients``) holds no samples; consumers
  that need one kind refuse the other.
- Geometry: spacing, origin and the box of voxel centres are checked by vgraph.volume_grid.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from vgraph import derived
from vgraph.errors import VGraphError
from vgraph.rank_table import RankTable
from vgraph.value_range import blockwise_extremes, checked_range, from_unit, range_of
from vgraph.volume_grid import (IDENTITY, Matrix3, VolumeGeometryError, box_corners, check_box,  # noqa: F401
                                checked_direction, checked_vec3, grid_affine, is_identity)
from vgraph.volume_texture import (FLOAT32_SAFE, SIXTEEN_BIT_CODES, SLAB_VOXELS, TEXTURE_FORMATS, sixteen_bit_codes,
                                   upload_texture)

Vec3 = tuple[float, float, float]

PRECISIONS = ("full", "16bit")  # of at_precision(): the stored values, or 16-bit codes
# What a volume keeps from its values alone (the grid does not enter): shared by with_overrides.
_VALUE_STATISTICS = ("nonfinite_count", "finite_extremes", "value_range", "_ranks", "_histograms")


@dataclass(eq=False)
class Volume:
    data: np.ndarray
    spacing: Vec3 = (1.0, 1.0, 1.0)
    origin: Vec3 = (0.0, 0.0, 0.0)
    declared_range: tuple[float, float] | None = None
    is_spline_coefficients: bool = False
    source: str = ""  # where the data came from, for messages
    time_steps: int = 1  # time points in the file this volume is one of (4D files)
    direction: Matrix3 = IDENTITY  # direction cosines in RAS; columns = the index axes
    holds_labels: bool = False  # the file declares label values, not intensities

    def __post_init__(self):
        where = f" from {self.source}" if self.source else ""
        data = np.asarray(self.data)
        if data.ndim != 3:
            raise VGraphError(f"volume{where}: expected a 3D [z, y, x] array, got shape {data.shape}")
        if 0 in data.shape:
            raise VGraphError(f"volume{where}: zero-size dimension in shape (z, y, x) = {data.shape}")
        if data.dtype.kind not in "uif":
            raise VGraphError(f"volume{where}: unsupported data type {data.dtype}")
        self.data = data
        self.spacing = checked_vec3(self.spacing, "spacing", where, positive=True)
        self.origin = checked_vec3(self.origin, "origin", where)
        self.direction = checked_direction(self.direction, where)
        check_box(self.dims, self.spacing, self.origin, where, self.direction)
        self.holds_labels = bool(self.holds_labels)
        self.declared_range = checked_range(self.declared_range, f"volume{where}")
        if isinstance(self.time_steps, bool) or not isinstance(self.time_steps, (int, np.integer)) \
                or self.time_steps < 1:
            raise VGraphError(f"volume{where}: time_steps must be a positive integer, "
                              f"got {self.time_steps!r}")
        self.time_steps = int(self.time_steps)

    @property
    def bricks(self):
        """The pyramid of bricks behind the volume (vgraph.bricks.BrickedVolume); None for a
        volume held as one array."""
        return None

    # --- geometry -------------------------------------------------------------------------------
    @property
    def dims(self) -> tuple[int, int, int]:
        """Voxel counts as (x, y, z)."""
        z, y, x = self.data.shape
        return (x, y, z)

    @property
    def extent(self) -> np.ndarray:
        """World-space size of the box spanned by the voxel centres, (x, y, z)."""
        return (np.array(self.dims) - 1) * np.array(self.spacing)

    @property
    def affine(self) -> np.ndarray:
        """4x4 float64: homogeneous voxel indices (i, j, k, 1) -> world points (RAS), as nibabel's."""
        return grid_affine(self.spacing, self.origin, self.direction)

    @property
    def is_axis_aligned(self) -> bool:
        """Whether the index axes are the world axes (identity direction)."""
        return is_identity(self.direction)

    def voxel_to_world(self, ijk) -> np.ndarray:
        """World points (..., 3) of voxel indices (..., 3) (i, j, k), fractional ones too."""
        scaled = np.asarray(ijk, dtype=float) * np.asarray(self.spacing)
        if self.is_axis_aligned:  # to the last bit as before directions existed
            return np.asarray(self.origin) + scaled
        return np.asarray(self.origin) + scaled @ np.asarray(self.direction).T

    def world_to_voxel(self, xyz) -> np.ndarray:
        offset = np.asarray(xyz, dtype=float) - np.asarray(self.origin)
        if not self.is_axis_aligned:  # the direction is orthonormal: its inverse is its transpose
            offset = offset @ np.asarray(self.direction)
        return offset / np.asarray(self.spacing)

    def world_box(self) -> tuple[np.ndarray, np.ndarray]:
        """(min, max) of the world corners of the box of voxel centres: the axis-aligned box that
        holds it (the box itself for an axis-aligned volume)."""
        corners = box_corners(self.dims, self.spacing, self.origin, self.direction)
        return corners.min(axis=0), corners.max(axis=0)

    # --- values ---------------------------------------------------------------------------------
    @cached_property
    def nonfinite_count(self) -> int:
        if self.data.dtype.kind != "f":
            return 0
        return int(self.data.size - np.count_nonzero(np.isfinite(self.data)))

    @cached_property
    def finite_extremes(self) -> tuple | None:
        """(min, max) of the finite voxels as numpy scalars of the data's type (exact for 64-bit
        integers), or None when no voxel is finite. Slab by slab: a mask of a big float volume
        would cost as much memory as the volume."""
        if not self.nonfinite_count:
            return self.data.min(), self.data.max()
        return blockwise_extremes(self._slabs())

    @cached_property
    def value_range(self) -> tuple[float, float]:
        if self.declared_range is not None:
            return self.declared_range
        return range_of(self.finite_extremes)

    def percentiles(self, percents) -> np.ndarray:
        """Data values at ``percents`` (each in [0, 100]) of the finite voxels, as np.percentile's
        default (linear) method gives them: exact for integer data spanning at most
        PERCENTILE_BINS (65536) values, otherwise within (max - min) / PERCENTILE_BINS. The histogram
        behind it is built once per volume, slab by slab. A volume without finite voxels maps
        percents linearly onto its value range."""
        p = np.asarray(percents, dtype=np.float64)
        if not (np.all(np.isfinite(p)) and np.all((p >= 0) & (p <= 100))):
            where = f" from {self.source}" if self.source else ""
            raise VGraphError(f"volume{where}: percentiles must lie in [0, 100], got {percents!r}")
        if self.finite_extremes is None:
            lo, hi = self.value_range
            return lo + p / 100.0 * (hi - lo)
        ranks = self._ranks
        position = p / 100.0 * (ranks.count - 1)  # np.percentile's 'linear': between order stats
        below = np.floor(position)
        above = np.minimum(below + 1, ranks.count - 1)
        low, high = ranks.value_at(below), ranks.value_at(above)
        fraction = position - below
        # weighted, not low + f (high - low): that difference overflows for data near +-1.8e308
        return low * (1.0 - fraction) + high * fraction

    @cached_property
    def _ranks(self) -> RankTable:
        """The table behind percentiles(): one pass over the data, then kept with the volume
        (a value statistic, its own: not derived data of vgraph.derived)."""
        return RankTable.of(self)

    @cached_property
    def _histograms(self) -> dict:
        """histogram() by its number of bins."""
        return {}

    def _slabs(self):
        flat = self.data.reshape(-1)
        for start in range(0, flat.size, SLAB_VOXELS):
            yield flat[start:start + SLAB_VOXELS]

    def normalized(self, values) -> np.ndarray:
        """Stored values -> normalised intensities (not clamped)."""
        lo, hi = self.value_range
        return (np.asarray(values, dtype=np.float64) - lo) / (hi - lo)

    def histogram(self, bins: int = 256) -> tuple[np.ndarray, np.ndarray]:
        """Counts of finite voxels in ``bins`` equal bins over the value range, and the bin edges
        in normalised intensity."""
        if bins not in self._histograms:
            # Binned in normalised float64 units, slab by slab: bins of a range such as
            # [3.4e38, 3.4e38 + 3e32] are not representable in the data's own float32.
            # Values a float32 rounding outside the range (a declared range computed in float64)
            # still count in the end bins.
            lo, hi = self.value_range
            # in Python floats: float32 arithmetic overflows for ranges near 1.8e308
            rounding = float(np.finfo(np.float32).eps) * max(abs(lo), abs(hi)) / (hi - lo)
            counts = np.zeros(bins, dtype=np.int64)
            for stored in self._slabs():
                slab = self.normalized(stored)
                inside = slab[(slab >= -rounding) & (slab <= 1.0 + rounding)]
                counts += np.histogram(np.clip(inside, 0.0, 1.0), bins=bins, range=(0.0, 1.0))[0]
            self._histograms[bins] = (counts, np.linspace(0.0, 1.0, bins + 1))
        return self._histograms[bins]

    def share_of_voxels(self, test) -> float:
        """Share of the finite voxels whose normalised intensities pass ``test`` (array ->
        booleans), slab by slab; 0 when no voxel is finite."""
        passed = total = 0
        for stored in self._slabs():
            if stored.dtype.kind == "f":
                stored = stored[np.isfinite(stored)]
            total += stored.size
            passed += int(np.count_nonzero(test(self.normalized(stored))))
        return passed / total if total else 0.0

    @property
    def constant_value(self) -> float | None:
        """The one value of every finite voxel when there is exactly one, else None (also when
        the extremes are not known without reading a volume larger than memory)."""
        extremes = self.finite_extremes
        if extremes is None or extremes[0] != extremes[1]:
            return None
        return float(extremes[0])

    # --- what a consumer needs -------------------------------------------------------------------
    def require_samples(self, consumer: str) -> "Volume":
        if self.is_spline_coefficients:
            raise VGraphError(f"{consumer} needs voxel samples but received B-spline coefficients: "
                              f"disable or remove the CubicSplineProcessor in front of it")
        return self

    def require_coefficients(self, consumer: str) -> "Volume":
        if not self.is_spline_coefficients:
            raise VGraphError(f"{consumer} needs B-spline coefficients but received voxel samples: "
                              f"insert a CubicSplineProcessor in front of it")
        return self

    # --- GPU ------------------------------------------------------------------------------------
    def at_precision(self, precision: str) -> "Volume":
        """The volume to sample at ``precision`` (PRECISIONS): itself for "full"; for "16bit" its
        16-bit copy (module docstring), made once and kept while the volume lives (vgraph.derived)."""
        if precision not in PRECISIONS:
            raise VGraphError(f"volume precision must be one of {', '.join(PRECISIONS)}, got {precision!r}")
        if precision == "full" or self.texture_is_r16:
            return self  # stored as R16 already: the copy would be the same texture
        return derived.value(self, "16-bit copy", lambda: SixteenBitCopy.of(self))

    def texture(self, ctx):
        """The volume as a 3D texture on ``ctx`` (R16 normalised for 8 and 16 bit, otherwise R32F), uploaded
        once per context and released with the volume or the context (vgraph.derived). Non-finite
        voxels are uploaded clamped to the value range so that no shader ever samples NaN."""
        return derived.value(self, "volume texture", lambda: upload_texture(self, ctx), ctx=ctx)

    def texture_scale_offset(self) -> tuple[float, float]:
        """(scale, offset) with normalised intensity = texture sample * scale + offset."""
        if self.texture_is_normalized:
            return 1.0, 0.0
        lo, hi = self.value_range
        full_scale = TEXTURE_FORMATS.get(self.data.dtype, (None, 1.0))[1]
        return full_scale / (hi - lo), -lo / (hi - lo)

    @property
    def texture_is_r16(self) -> bool:
        """Whether the texture is R16 normalised (8- and 16-bit data, 16-bit copies): its texels
        are vgraph.volume_texture.r16_texels(data)."""
        return self.data.dtype in TEXTURE_FORMATS

    @property
    def texture_is_normalized(self) -> bool:
        """Whether the texture holds normalised intensities (float32 cannot carry the values)."""
        if self.texture_is_r16:
            return False
        lo, hi = self.value_range
        return max(abs(lo), abs(hi)) > FLOAT32_SAFE or hi - lo < 1.0 / FLOAT32_SAFE

    def with_data(self, data: np.ndarray, **changes) -> "Volume":
        """A new volume on the same grid with other voxel values."""
        fields = dict(spacing=self.spacing, origin=self.origin, declared_range=self.declared_range,
                      is_spline_coefficients=self.is_spline_coefficients, source=self.source,
                      time_steps=self.time_steps, direction=self.direction, holds_labels=self.holds_labels)
        fields.update(changes)
        return Volume(data, **fields)

    def with_overrides(self, spacing=None, origin=None, declared_range=None, direction=None) -> "Volume":
        """The same voxels (the array is shared, the type kept) on another grid or with another
        value range, as BrickedVolume.with_overrides. With the value range unchanged, what was
        worked out from the values so far (extremes, counts, percentiles, histograms) is kept:
        a ray caster's copy in a box's normalised frame does not read the voxels again."""
        changes = {"spacing": spacing or self.spacing, "origin": origin or self.origin,
                   "direction": self.direction if direction is None else direction}
        if declared_range is not None:
            changes["declared_range"] = declared_range
        volume = dataclasses.replace(self, **changes)
        if declared_range is None:
            keep_value_statistics(self, volume)
        return volume


def keep_value_statistics(source: Volume, target: Volume) -> None:
    """Give ``target``, which holds ``source``'s values on another grid or in another order, what
    ``source`` worked out from its values alone (extremes, counts, percentiles, histograms), so
    that they are not read again."""
    target.__dict__.update({key: value for key, value in source.__dict__.items() if key in _VALUE_STATISTICS})


@dataclass(eq=False)
class SixteenBitCopy(Volume):
    """A volume as 16-bit codes q over the original's value range (Volume.at_precision): ``data``
    holds q (uint16), ``value_range`` stays the original's (so transfer functions in data values
    keep their places), normalised intensity = q / 65535, the texture R16 normalised, which the
    GL samples as q / 65535 directly. Percentiles are the codes' mapped into data values. Every
    consumer of normalised intensities (block ranges for skipping, the CPU reference, histograms)
    sees the quantised values the shaders sample."""

    @classmethod
    def of(cls, volume: Volume) -> "SixteenBitCopy":
        lo, hi = volume.value_range
        return cls(sixteen_bit_codes(volume), spacing=volume.spacing, origin=volume.origin,
                   declared_range=(lo, hi), is_spline_coefficients=volume.is_spline_coefficients,
                   source=volume.source, time_steps=volume.time_steps, direction=volume.direction,
                   holds_labels=volume.holds_labels)

    def normalized(self, values) -> np.ndarray:
        return np.asarray(values, dtype=np.float64) / SIXTEEN_BIT_CODES

    def texture_scale_offset(self) -> tuple[float, float]:
        return 1.0, 0.0  # R16 normalised: the GL returns q / 65535

    def percentiles(self, percents) -> np.ndarray:
        lo, hi = self.value_range
        return from_unit(super().percentiles(percents) / SIXTEEN_BIT_CODES, lo, hi)

    def at_precision(self, precision: str) -> "Volume":
        if precision not in PRECISIONS:
            raise VGraphError(f"volume precision must be one of {', '.join(PRECISIONS)}, got {precision!r}")
        return self  # its full precision is its 16 bits

    def with_data(self, data: np.ndarray, **changes) -> "Volume":
        raise VGraphError("a 16-bit copy holds codes, not data values: take with_data() of the original volume")
