"""Variants timed in alternation, the way every comparison of the bench is timed (issue #31).

Timing variant A's frames, then B's, lets load from other processes on a shared machine fall on one
of them only (a tile took 9.7 s in one phase and 6.8 s in the next). Here every variant draws one
untimed warm-up frame, then the variants take turns, one frame each per round, so drift hits all
alike; the spread (min / median / max) goes beside every number.
"""

from __future__ import annotations

import numpy as np


def interleaved(variants: dict, arguments, warm_up_argument) -> tuple[dict, list[tuple[int, str]]]:
    """``variants``: name -> frame(argument) -> seconds. Each draws one untimed frame with
    ``warm_up_argument`` (compile, upload, build tables), then round r calls every variant in turn
    with ``arguments[r]`` (a camera, or None). Returns each variant's seconds and the order of the
    timed frames as (round, name)."""
    for frame in variants.values():
        frame(warm_up_argument)
    seconds, order = {name: [] for name in variants}, []
    for round_index, argument in enumerate(arguments):
        for name, frame in variants.items():
            seconds[name].append(frame(argument))
            order.append((round_index, name))
    return seconds, order


def spread(values, digits: int = 3) -> str:
    """'min / median / max' of a variant's seconds."""
    if len(values) == 0:
        return "(not run)"
    return f"{min(values):.{digits}f} / {float(np.median(values)):.{digits}f} / {max(values):.{digits}f}"
