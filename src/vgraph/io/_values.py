"""Stored values to volume values: numbers written as text, and the linear rescaling of NIfTI
(scl_slope, scl_inter) and DICOM (RescaleSlope, RescaleIntercept)."""

from __future__ import annotations

import numpy as np

from vgraph.errors import VolumeFileError

_LONGEST_NUMBER = 1024


# --- numbers as text (NRRD ascii encoding, VTI ascii arrays) --------------------------------------
def ascii_values(pieces, dtype: np.dtype, count: int, file, field: str) -> np.ndarray:
    """Exactly ``count`` whitespace-separated numbers of ``dtype`` from text ``pieces`` (str or
    bytes, split anywhere), converted piece by piece so that a huge text never becomes one huge
    list of Python strings. More or fewer numbers than declared, or a word that is not a number
    of that type, are refused."""
    dtype = np.dtype(dtype).newbyteorder("=")
    out = np.empty(count, dtype=dtype)
    filled, carry = 0, ""
    for piece in pieces:
        text = carry + (piece.decode("latin-1") if isinstance(piece, bytes) else piece)
        cut = max(text.rfind(c) for c in " \t\r\n\f\v")  # the last word may go on in the next piece
        words, carry = text[:cut + 1].split(), text[cut + 1:]
        if len(carry) > _LONGEST_NUMBER:  # no number is this long; and carrying it on is quadratic
            raise VolumeFileError(file, f"not a list of numbers: a word of more than "
                                        f"{_LONGEST_NUMBER} characters", field)
        filled = _put_words(out, filled, words, file, field)
    filled = _put_words(out, filled, carry.split(), file, field)
    if filled < count:
        raise VolumeFileError(file, f"found {filled} values, fewer than the {count} the header "
                                    f"declares", field)
    return out


def _put_words(out: np.ndarray, filled: int, words: list[str], file, field: str) -> int:
    if not words:
        return filled
    if filled + len(words) > len(out):
        raise VolumeFileError(file, f"more values than the {len(out)} the header declares", field)
    try:
        out[filled:filled + len(words)] = np.array(words, dtype=out.dtype)
    except (ValueError, OverflowError) as exc:
        raise VolumeFileError(file, f"not a list of {out.dtype} values: {exc}", field) from None
    return filled + len(words)


# --- value scaling (NIfTI scl_slope, DICOM RescaleSlope) -----------------------------------------
FLOAT32_MAX = float(np.finfo(np.float32).max)


def rescaled(stored: np.ndarray, slopes, intercepts) -> np.ndarray:
    """stored * slope + intercept computed in float64, one slice (along axis 0) at a time, with
    a slope and intercept per slice (scalars apply to all). The result is float32 when the stored
    values have at most 16 bits or are float32 and every finite result lies within float32's
    range; otherwise float64, since rounding to float32 would turn the large values into +-Inf
    (and lose digits of wider stored types)."""
    slices = stored.shape[0]
    slopes = np.broadcast_to(np.asarray(slopes, dtype=np.float64), (slices,))
    intercepts = np.broadcast_to(np.asarray(intercepts, dtype=np.float64), (slices,))
    narrow = (stored.dtype.kind in "ui" and stored.dtype.itemsize <= 2) or stored.dtype == np.float32
    fits = all(_largest_result(stored[k], slopes[k], intercepts[k]) <= FLOAT32_MAX
               for k in range(slices))
    out = np.empty(stored.shape, dtype=np.float32 if narrow and fits else np.float64)
    for k in range(slices):
        out[k] = stored[k].astype(np.float64) * slopes[k] + intercepts[k]
    return out


def _largest_result(values: np.ndarray, slope: float, intercept: float) -> float:
    """The largest finite |value * slope + intercept| (the map is linear: the ends decide)."""
    if values.dtype.kind == "f":
        values = values[np.isfinite(values)]
    if values.size == 0:
        return 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        ends = np.array([values.min(), values.max()], dtype=np.float64) * slope + intercept
    ends = ends[np.isfinite(ends)]
    return float(np.abs(ends).max()) if ends.size else 0.0
