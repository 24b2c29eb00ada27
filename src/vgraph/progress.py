"""Progress of an evaluation: which processor runs, and how far its steps are.

The scheduler announces each processor as it starts (``running``); work with steps (reading a
file, prefiltering, reading bricks) says how far it is with ``report(done, total, what)``,
wherever it runs: in ``process()`` (``Processor.report_progress``) or in a reader or a numeric
routine that a processor calls. Whoever wants to know (the GUI's render process, a script)
installs a listener with ``listening(callback)``; ``callback`` receives a ``Progress`` for
each announcement and report. With nobody listening, ``report`` returns at once, so code may
report as often as it likes (a per-chunk call costs a function call and a test).

Why a process-wide listener and not a context variable: work that a processor hands to a thread
pool may report from the pool's threads, where a context variable set by the scheduler is not
seen. One evaluation runs at a time per process (one GL context), so one current processor is
enough.

``Steps`` is the helper for a loop with steps: it shows a tqdm bar on the terminal (as the
readers did before) and reports the same counts to the listener.
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable

from tqdm import tqdm


@dataclass(frozen=True)
class Progress:
    """``processor`` (an id, of type ``type_name``) runs; it has done ``done`` of ``total`` steps
    of ``what`` (``total`` 0: no steps known, only that it runs). ``processor`` "": work of the
    evaluating program that belongs to no processor (the GUI's histograms)."""
    processor: str
    type_name: str
    what: str = ""
    done: float = 0.0
    total: float = 0.0
    started: float = 0.0   # time.monotonic() when the processor started

    @property
    def fraction(self) -> float | None:
        """done / total in [0, 1], or None when the work has no known steps."""
        if self.total <= 0:
            return None
        return min(1.0, max(0.0, self.done / self.total))

    def describe(self) -> str:
        """One line for a status bar: 'source (VolumeSource): reading head.raw 45%'."""
        line = f"{self.processor} ({self.type_name})" if self.processor else ""
        if self.what:
            line += f": {self.what}" if line else self.what
        fraction = self.fraction
        if fraction is not None:
            line += f" {fraction * 100:.0f}%"
        return line


Listener = Callable[[Progress], None]
_listeners: list[Listener] = []
_current: Progress | None = None   # the processor that runs now (with its last report)


@contextmanager
def listening(callback: Listener):
    """Call ``callback(Progress)`` for every processor start and report inside the block."""
    _listeners.append(callback)
    try:
        yield
    finally:
        _listeners.remove(callback)


def is_listened() -> bool:
    return bool(_listeners)


def current() -> Progress | None:
    """The processor running now, with its last report (None between processors)."""
    return _current


@contextmanager
def running(processor_id: str, type_name: str):
    """The scheduler's announcement: ``processor_id`` runs inside the block (nesting restores
    the outer one: a processor that evaluates a network of its own)."""
    global _current
    outer = _current
    _current = Progress(processor_id, type_name, started=time.monotonic())
    _tell(_current)
    try:
        yield
    finally:
        _current = outer


def report(done: float, total: float, what: str = "") -> None:
    """The running processor has done ``done`` of ``total`` steps of ``what``. Nothing happens
    when nobody listens or no processor runs (a reader called from a script)."""
    global _current
    if not _listeners or _current is None:
        return
    _current = Progress(_current.processor, _current.type_name, what, float(done), float(total),
                        _current.started)
    _tell(_current)


def _tell(progress: Progress) -> None:
    for listener in list(_listeners):
        listener(progress)


class Steps:
    """A tqdm bar (on stderr; ``show``: True = always, None = when stderr is a terminal, False =
    never) that also reports its counts to the listener, always."""

    def __init__(self, total: float, what: str, show: bool | None = None, **tqdm_options):
        self.total, self.what, self.done = total, what, 0.0
        disable = {True: False, None: None, False: True}[show]  # tqdm's word for it
        self.bar = tqdm(total=total, desc=what, leave=False, disable=disable, **tqdm_options)
        report(0, total, what)

    def update(self, steps: float = 1) -> None:
        self.done += steps
        self.bar.update(steps)
        report(self.done, self.total, self.what)

    def set(self, done: float) -> None:
        """Jump to ``done`` steps (for work that reports a fraction)."""
        self.update(done - self.done)

    def close(self) -> None:
        self.bar.close()

    def __enter__(self) -> "Steps":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def steps(iterable, what: str, total: int | None = None, show: bool | None = None, **tqdm_options):
    """Iterate ``iterable``, counting each item as a step (``Steps``)."""
    items = list(iterable) if total is None and not hasattr(iterable, "__len__") else iterable
    with Steps(len(items) if total is None else total, what, show, **tqdm_options) as bar:
        for item in items:
            yield item
            bar.update()
