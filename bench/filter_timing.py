"""A filter processor timed against the library call it equals (bench_volume_filters.py,
bench_volume_segmentation.py): the two take turns after an untimed warm-up (interleave.py), and
each case is a markdown row of min / median / max seconds and the ratio of the medians, under a
line that names the machine, the volume and the rounds."""

from __future__ import annotations

import os
import platform
import time

import numpy as np
from scipy import ndimage

from interleave import interleaved, spread
from vgraph.io import read_volume
from vgraph.volume import Volume


def bonsai(data, size: int = 256) -> Volume:
    """The CT bonsai (256^3 uint8, spacing 1), or resampled to ``size``^3 (linear, spacing 1: the
    bench's world sizes stay voxel sizes) for the larger rows."""
    volume = read_volume(data / "ct_bonsai" / "bonsai.nii.gz")
    if size == volume.dims[0]:
        return volume
    zoomed = ndimage.zoom(volume.data, size / np.array(volume.data.shape), order=1)
    return Volume(zoomed.astype(volume.data.dtype))


def timed(run) -> float:
    start = time.perf_counter()
    run()
    return time.perf_counter() - start


def table_header(volume, rounds: int) -> list[str]:
    lines = [f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
             f"{volume.dims} {volume.data.dtype}, {rounds} rounds", "",
             "| filter | processor | ours s (min / median / max) | reference s | ours / reference |",
             "|---|---|---|---|---|"]
    print("\n".join(lines), flush=True)
    return lines


def ours_against_reference(name: str, type_name: str, ours, reference, rounds: int) -> str:
    """The row of case ``name``: ``ours()`` (the processor) and ``reference()`` interleaved."""
    variants = {"ours": lambda _: timed(ours), "reference": lambda _: timed(reference)}
    seconds, _ = interleaved(variants, [None] * rounds, None)
    ratio = np.median(seconds["ours"]) / np.median(seconds["reference"])
    row = f"| {name} | {type_name} | {spread(seconds['ours'])} | {spread(seconds['reference'])} | {ratio:.2f} |"
    print(row, flush=True)
    return row
