"""The render process: a child process that owns the OpenGL context and evaluates for the GUI.

Why a process: moderngl holds the GIL while it renders, so rendering in a thread of the GUI process
would freeze the window for a whole frame; and the GUI then needs no GL at all, so it runs (and is
tested) anywhere Qt runs. The GUI sends what to show, the render process sends frames back.
What they send: vgraph.live.render_messages; what the child does: vgraph.live.render_server.

``RenderProcess`` is the GUI's handle (no Qt): ``submit`` a job, ``poll``/``wait`` for the result.
If the process dies (a driver crash), the result says so with its exit code and the next job
starts a new one; a job that never finishes (a stopped or stuck process) can be ``cancel``led.
"""

from __future__ import annotations

import multiprocessing
import signal
import statistics
import time
from collections import deque

from vgraph import progress as progress_api
from vgraph.errors import VGraphError
from vgraph.live.probes import Probe, ProbeAnswer
from vgraph.live.progress_messages import ProcessorProgress
from vgraph.live.render_messages import RenderJob, RenderProgress, RenderResult
from vgraph.live.render_server import serve

RECENT_JOBS = 20   # how many recent jobs say how long a job usually takes


def describe_exit(code: int | None) -> str:
    """'exit code 1', or for a process killed by a signal 'exit code -9 (SIGKILL)'."""
    if code is not None and code < 0:
        try:
            return f"exit code {code} ({signal.Signals(-code).name})"
        except ValueError:
            pass
    return f"exit code {code}"


class RenderProcess:
    """Starts the render process on first use; jobs are answered one result each, in order.

    Usually one job is in flight; a job submitted while others are goes behind them (the GUI does
    so while the mouse drags). The render process renders only the newest of the jobs that
    wait when it gets to them; the older ones come back ``skipped`` (their changes applied).

    For the GUI's watchdog (``LiveEvaluation``): ``elapsed()`` is how long the job in flight has
    been running, ``typical_seconds()`` the median of the last ``RECENT_JOBS`` jobs, ``died()`` the
    exit code of a process that ended by itself, ``cancel()`` kills the process of a job that does
    not finish and ``start()`` puts a new one in its place."""

    def __init__(self):
        self._process = None
        self._connection = None
        self._probes = None      # the probe pipe (send_probe)
        self._probes_out = 0
        self.jobs: deque[RenderJob] = deque()  # in flight, oldest first
        self.job_started = 0.0              # time.monotonic() when the oldest job began, as seen from here
        self.recent_seconds: deque[float] = deque(maxlen=RECENT_JOBS)   # of the current network's jobs
        self.history = 0   # counts fresh jobs: a job of an earlier network does not count in recent_seconds
        self.starts = 0                     # processes started so far
        self.progress: RenderProgress | None = None  # the last progress of the job in flight
        self.running: progress_api.Progress | None = None  # the processor running in that job

    @property
    def job(self) -> RenderJob | None:
        """The oldest job in flight: the one the render process works on."""
        return self.jobs[0] if self.jobs else None

    @property
    def busy(self) -> bool:
        return bool(self.jobs)

    @property
    def in_flight(self) -> int:
        return len(self.jobs)

    @property
    def pid(self) -> int | None:
        """The render process's id (None before the first job and after ``stop``)."""
        return self._process.pid if self._process is not None else None

    def elapsed(self) -> float:
        return time.monotonic() - self.job_started if self.busy else 0.0

    def typical_seconds(self) -> float | None:
        """The median time of the current network's recent jobs (None before its first answer)."""
        return statistics.median(self.recent_seconds) if self.recent_seconds else None

    def died(self) -> int | None:
        """The exit code if the render process ended without being asked to (else None)."""
        if self._process is None or self._process.is_alive():
            return None
        return self._process.exitcode

    def submit(self, job: RenderJob) -> None:
        # With jobs in flight a dead process is poll()'s to report (for them all), not to replace.
        if not self.jobs and (self._process is None or not self._process.is_alive()):
            self.start()
        if not self.jobs:
            self.job_started = time.monotonic()
            self.progress = self.running = None
        if job.fresh:   # another network: its frames are compared with its own, not the last one's
            self.history += 1
            self.recent_seconds.clear()
        job.sent, job.history = time.monotonic(), self.history
        self.jobs.append(job)
        try:
            self._connection.send(job)
        except (OSError, ValueError):
            pass  # the process died: poll() reports it

    def poll(self) -> RenderResult | None:
        """The result of the job in flight if it is ready."""
        if not self.busy:
            return None
        try:
            while True:  # progress messages first, then the job's one result
                if not self._connection.poll():
                    if self._process.is_alive():
                        return None
                    raise EOFError
                result = self._connection.recv()
                if isinstance(result, ProcessorProgress):
                    self.running = result.progress
                    continue
                if not isinstance(result, RenderProgress):
                    break
                self.progress = result
            now = time.monotonic()
            if not result.skipped and self.job.history == self.history:
                self.recent_seconds.append(now - max(self.job_started, result.started))
            result.submitted, result.received = self.job.sent, now
            self.jobs.popleft()
            self.running = None  # the next job announces its own
            self.job_started = now  # the next one (if any) runs from now
        except (EOFError, OSError):
            self._process.join(timeout=1.0)
            result = RenderResult(self.job.version, self.job.scale, error=(
                f"the render process stopped unexpectedly ({describe_exit(self._process.exitcode)})"))
            self._discard()
            self.jobs.clear()  # the jobs behind it died with it
        return result

    def wait(self, timeout: float = 120.0) -> RenderResult:
        deadline = time.monotonic() + timeout
        while self.busy:
            result = self.poll()
            if result is not None:
                return result
            if time.monotonic() > deadline:
                raise VGraphError(f"the render process gave no result within {timeout:.0f} s")
            self._connection.poll(0.05)
        raise VGraphError("no job was submitted")

    def start(self) -> None:
        """Start a new render process (ending the current one, if any)."""
        self._discard()
        context = multiprocessing.get_context("spawn")
        self._connection, child = context.Pipe()
        self._probes, child_probes = context.Pipe()  # the hover readout's (vgraph.live.probes)
        self._probes_out = 0
        self._process = context.Process(target=serve, args=(child, child_probes), name="vgraph-render",
                                        daemon=True)
        self._process.start()
        child.close()
        child_probes.close()
        self.starts += 1

    def cancel(self) -> None:
        """Give up the job in flight: its process is killed (``start`` or the next job makes a new one)."""
        self._discard()
        self.jobs.clear()

    # --- the hover readout's probes (vgraph.live.probes) ---------------------------------------
    def send_probe(self, probe: Probe) -> bool:
        """Ask what lies under a pixel; False (nothing sent) while no render process runs. The
        answer comes with ``probe_answer`` after the job in flight, if any, is done."""
        if self._process is None or not self._process.is_alive():
            return False
        try:
            self._probes.send(probe)
        except (OSError, ValueError):
            return False
        self._probes_out += 1
        return True

    @property
    def probes_out(self) -> int:
        """Probes sent and not answered yet (0 after a new process started)."""
        return self._probes_out if self._process is not None else 0

    def probe_answer(self, timeout: float = 0.0) -> ProbeAnswer | None:
        """The next answer to a probe, waiting at most ``timeout`` seconds; None if none came."""
        if self._process is None or not self._probes_out:
            return None
        try:
            if not self._probes.poll(timeout):
                return None
            answer = self._probes.recv()
        except (EOFError, OSError):
            self._probes_out = 0  # the process died: poll() reports it
            return None
        self._probes_out -= 1
        return answer

    def _discard(self) -> None:
        if self._connection is not None:
            self._connection.close()
            self._probes.close()
        if self._process is not None:
            if self._process.is_alive():
                self._process.kill()   # SIGKILL: a stopped (SIGSTOP) process ignores SIGTERM
            self._process.join(timeout=5)  # reaped, so no zombie is left behind
        self._process = self._connection = self._probes = None

    def stop(self) -> None:
        if self._process is not None and self._process.is_alive():
            try:
                self._connection.send(None)
                self._process.join(timeout=5)
            except (OSError, ValueError):
                pass
        self._discard()
        self.jobs.clear()
