"""What the user of bench/bench_gui_session.py waits for, timed: the ``Wait`` rows of its table and
the ``FrameLog`` of one canvas (when each frame was given to it and first painted)."""

from __future__ import annotations

import time
from dataclasses import dataclass


@dataclass
class Wait:
    step: str         # what the user did
    waits_for: str    # what the user waits for
    seconds: float    # from the input (or the launch) to it
    detail: str = ""


class FrameLog:
    """Frames given to the canvas ``canvas`` and when each was first painted (an event filter on
    its view)."""

    def __init__(self, window, canvas: str):
        from PySide6.QtCore import QEvent, QObject
        self.canvas = canvas
        self.frames: list[list] = []   # [time given, final, time first painted or None]
        self.results: list = []        # every RenderResult received (the render process's timestamps)
        window.evaluation.frames.connect(self._given)
        window.evaluation.received.connect(self.results.append)
        log = self

        class Painted(QObject):
            def eventFilter(self, watched, event):
                if event.type() == QEvent.Paint and log.frames and log.frames[-1][2] is None:
                    log.frames[-1][2] = time.monotonic()
                return False
        self.filter = Painted()
        window.canvases.views[canvas].installEventFilter(self.filter)

    def _given(self, frames: dict, final: bool) -> None:
        if self.canvas in frames:
            self.frames.append([time.monotonic(), bool(final), None])

    def refined_after(self, mark: float) -> float | None:
        """When the first full frame given after ``mark`` was painted (None: not yet)."""
        for given, final, painted in self.frames:
            if given >= mark and final and painted is not None:
                return painted
        return None

    def render_time_of(self, painted: float) -> str:
        """What the render process did for the full frame painted at ``painted``."""
        full = [r for r in self.results if r.scale == 1.0 and r.outcome.frames and r.received <= painted]
        if not full:
            return ""
        result = full[-1]
        return (f"render process: started {painted - result.started:.2f} s before the paint, "
                f"evaluated in {result.seconds:.2f} s")

    def shown_between(self, start: float, end: float) -> int:
        return sum(1 for _, _, painted in self.frames if painted is not None and start <= painted <= end)

    def refined(self, window, waits: list[Wait], step: str, mark: float, detail: str = ""):
        """Wait (a session step) for the refined image after ``mark``; note it in ``waits``."""
        yield lambda: self.refined_after(mark) is not None and window.evaluation.idle()
        painted = self.refined_after(mark)
        waits.append(Wait(step, "refined image", round(painted - mark, 3),
                          "; ".join(d for d in (detail, self.render_time_of(painted)) if d)))
