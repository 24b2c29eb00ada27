"""The GUI's hover readout, render side: what lies under the mouse in a canvas (issue 36).

The GUI holds no volume and no depth image, so it asks the render process: a ``Probe`` (canvas,
pixel of the frame it shows, that frame's size) travels on the render process's probe pipe (a
second pipe beside the jobs', vgraph.live.render_process, so a probe never waits behind the
jobs' bookkeeping), and comes back as a ``ProbeAnswer`` holding ``Network.pick``'s result
(vgraph.picking) or why there is none. The pick reads the renderer's depth of the frame already
drawn (its depth output is drawn once per frame, on the first probe, then read pixel by pixel),
so a probe costs a pixel read and a few samples: far more than 30 a second (bench/bench_hover.py).
The texts the GUI shows (status bar, corner annotation) are made here, with no Qt.
"""

from __future__ import annotations

from dataclasses import dataclass

from vgraph.errors import VGraphError
from vgraph.picking import PickResult, pick


@dataclass(frozen=True)
class Probe:
    canvas: str
    x: float                  # pixel column and row in the shown frame (row 0 at the top)
    y: float
    size: tuple[int, int]     # the shown frame's (width, height)
    serial: int = 0           # the GUI's count, to match answers to probes


@dataclass(frozen=True)
class ProbeAnswer:
    serial: int
    canvas: str
    result: PickResult | None  # None: ``error`` says why
    error: str = ""


def answer(network, probe: Probe, context=None) -> ProbeAnswer:
    """Pick ``probe``'s pixel in ``network`` (the render process's mirror of the GUI's), whose
    last frame was drawn with ``context`` (its FrameContext: the pick evaluates with the same, so
    that the frame is read, not drawn again)."""
    if network is None:
        return ProbeAnswer(probe.serial, probe.canvas, None, "nothing rendered yet")
    try:
        result = pick(network, probe.canvas, probe.x, probe.y, size=probe.size, context=context)
    except VGraphError as error:
        return ProbeAnswer(probe.serial, probe.canvas, None, str(error))
    return ProbeAnswer(probe.serial, probe.canvas, result)


def _number(value: float | None) -> str:
    return "-" if value is None else f"{value:.6g}"


def _position(result: PickResult) -> str:
    point = result.surface.point if result.surface is not None else result.point
    return "(" + ", ".join(f"{v:.2f}" for v in point) + ")"


def status_text(answer: ProbeAnswer) -> str:
    """One line for the status bar."""
    if answer.result is None:
        return answer.error
    result = answer.result
    if not result.hit:
        return f"{result.canvas}: {result.reason}"
    parts = [f"{result.canvas}: {_position(result)}"]
    if result.voxel is not None:
        parts.append(f"voxel {result.voxel}")
    for sample in result.samples:
        shown = sample.label if sample.label else _number(sample.value)
        parts.append(f"{sample.source} {shown}")
    if result.surface is not None:
        parts.append(f"k1 {result.surface.k1:.4g}, k2 {result.surface.k2:.4g}")
    return "   ".join(parts)


def corner_lines(answer: ProbeAnswer) -> list[str]:
    """The corner annotation, a few short lines (Slicer's data probe style)."""
    if answer.result is None or not answer.result.hit:
        return []
    result = answer.result
    lines = [f"{'surface' if result.surface is not None else 'point'} {_position(result)}"]
    if result.voxel is not None:
        lines.append("voxel (" + ", ".join(str(v) for v in result.voxel) + ")")
    for sample in result.samples:
        shown = f"{_number(sample.value)} {sample.label}" if sample.label else _number(sample.value)
        lines.append(f"{sample.source.split('.')[0]}: {shown}")
    if result.surface is not None:
        surface = result.surface
        lines.append("normal (" + ", ".join(f"{v:.2f}" for v in surface.normal) + ")")
        lines.append(f"k1 {surface.k1:.4g}  k2 {surface.k2:.4g}")
    return lines
