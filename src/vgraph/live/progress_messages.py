"""What the render process tells the window about the processor it runs (``render_process``).

A ``ProgressForwarder`` is the ``vgraph.progress`` listener the render process installs while it
evaluates a job; it sends ``ProcessorProgress`` messages through the pipe, thinned: a processor's
start, the first report of each kind of work and its last step go at once (the window must know
what runs even if the work then blocks), the steps between at most every ``PROGRESS_INTERVAL``
seconds (a progress bar needs no more, and a fast frame of a drag should cost a few messages).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from vgraph import progress as progress_api

PROGRESS_INTERVAL = 0.05  # seconds between two messages of one kind of work


@dataclass
class ProcessorProgress:
    """Sent while a job is evaluated: which processor runs and how far it is."""
    version: int
    progress: progress_api.Progress


class ProgressForwarder:
    """A ``vgraph.progress`` listener that sends through ``send`` each processor's start, the
    first report of each kind of work (``what``, ``total``) and its last step at once, and the
    steps between at most every ``interval`` seconds."""

    def __init__(self, send, version: int, interval: float = PROGRESS_INTERVAL):
        self.send, self.version, self.interval = send, version, interval
        self._last: tuple = (None, 0.0)   # ((processor, what, total), time.monotonic()) last sent

    def __call__(self, progress: progress_api.Progress) -> None:
        now = time.monotonic()
        kind = (progress.processor, progress.what, progress.total)
        last_kind, sent = self._last
        last_step = progress.total > 0 and progress.done >= progress.total
        if kind == last_kind and now - sent < self.interval and not last_step:
            return
        self._last = (kind, now)
        self.send(ProcessorProgress(self.version, progress))
