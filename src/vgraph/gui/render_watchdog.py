"""The watchdog of the GUI's render process (``RenderWatchdog``, mixed into LiveEvaluation,
live_evaluation.py): what keeps the window honest about a process it cannot see otherwise.

``check_renderer`` runs every ``WATCHDOG_MS``:
- a job running longer than ``stall_limit()`` (``STALL_MIN_SECONDS``, or ``STALL_FACTOR`` times
  the median of the same network's recent jobs if that is longer; ``STALL_FIRST_SECONDS`` before
  the network's first frame, which loads its data) is reported once through ``warning``, with
  the processor running, and then every tick through ``stalled(seconds)``; ``cancel()`` kills
  that process and starts a new one. After a cancel nothing is sent until the next change, so a
  network that hangs the render process does not hang it again at once;
- a render process found dead, busy or idle, is reported through ``crashed`` with its exit code
  and replaced at once; every replacement is reported through ``info`` with the new process id.
"""

from __future__ import annotations

from vgraph.live.evaluator import format_seconds
from vgraph.live.render_process import describe_exit

WATCHDOG_MS = 1000
STALL_MIN_SECONDS = 10.0    # no job is called stuck sooner (loading a large volume takes a while)
STALL_FACTOR = 10.0         # ... nor before it took this many times as long as recent jobs
STALL_FIRST_SECONDS = 60.0  # a network's first frame, with nothing of its own to compare: it loads


class RenderWatchdog:
    """Stall reports, dead-process replacement and cancel for LiveEvaluation (a mix-in before
    QObject: it brings ``renderer``, the stall settings, ``poller`` and the signals)."""

    def stall_limit(self) -> float:
        """Seconds after which the job in flight is reported as overdue: compared with this
        network's frames (the render process forgets the last network's when a fresh job starts)."""
        typical = self.renderer.typical_seconds()
        if typical is None:
            return max(self.stall_min_seconds, self.stall_first_seconds)
        return max(self.stall_min_seconds, self.stall_factor * typical)

    def check_renderer(self) -> None:
        """Report an overdue job; report and replace a render process that died while idle (one
        that dies with a job is found by the poller and reported with that job)."""
        if self.renderer.busy:
            seconds = self.renderer.elapsed()
            if seconds > self.stall_limit():
                self._report_stall(seconds)
        else:
            self._replace_if_dead(" while idle")

    def _report_stall(self, seconds: float) -> None:
        if not self._stall_reported:
            self._stall_reported = True
            typical = self.renderer.typical_seconds()
            usual = (f", this network's recent frames took {format_seconds(typical)}" if typical
                     else ", the first frame of this network")
            running = getattr(self.renderer, "running", None)
            now = f" (running {running.describe()})" if running is not None and running.describe() else ""
            self.warning.emit(f"the render process has been working on one frame for "
                              f"{format_seconds(seconds)}{now}{usual}; it may be stuck: "
                              f"Network > Cancel Rendering stops it")
        self.stalled.emit(seconds)

    def _replace_if_dead(self, when: str) -> None:
        code = self.renderer.died()
        if code is not None:
            self.crashed.emit(f"the render process stopped unexpectedly{when} ({describe_exit(code)})")
            self._replace()

    def _replace(self) -> None:
        self.renderer.start()
        self._fresh = True
        self.info.emit(f"started a new render process (pid {self.renderer.pid})")

    def cancel(self) -> bool:
        """Give up the frame in flight: kill the render process and start a new one (False if
        there was nothing to cancel)."""
        if not self.renderer.busy:
            return False
        seconds, pid = self.renderer.elapsed(), self.renderer.pid
        self.poller.stop()
        self.renderer.cancel()
        self._wanted = self._stall_reported = False
        self.warning.emit(f"cancelled a frame after {format_seconds(seconds)}: "
                          f"stopped the render process (pid {pid})")
        self._replace()
        self.busy_changed.emit(False)
        return True
