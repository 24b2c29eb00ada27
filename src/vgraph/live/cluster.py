"""Rendering the GUI's final frames on a Dask cluster (issue #15; docs/guide/distributed.md, "From the GUI").

The GUI's cluster setting (``ClusterSetting``: ``local:N`` or ``tcp://HOST:PORT``, the split, the
tiles grid) travels in every ``RenderJob``. The render process (``RenderServer``) then draws the
final, full-size frames of its displays through ``vgraph.distributed.render``; coarse frames while
the mouse drags, and runs with writers, stay local (a drag must answer at once, and writers write
what ``vgraph run`` writes in one process).

``ClusterRenderer`` lives in the render process (no Qt here):
- It keeps the Client (and a LocalCluster it started) open between jobs: a cluster takes seconds to
  start and its workers keep the network they built (vgraph.distributed.worker), so only the first
  frame pays for them. It closes them when the setting changes or is cleared, and when the render
  process stops.
- A cluster that cannot be reached, or a frame the cluster cannot draw (a network that cannot be
  tiled, a lost connection), falls back to a local frame with a warning the window logs; an
  unreachable address is tried again only after ``RETRY_SECONDS``, so every edit does not wait for
  the connect timeout.
- Progress: ``render()`` blocks until the picture is assembled, so it runs in a thread while this
  thread counts the client's finished futures (the render process's client runs nothing else) and
  reports (done, total) every ``PROGRESS_SECONDS``.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import threading
import time
from dataclasses import dataclass

import networkx as nx
import numpy as np

from vgraph.distributed import connect as connect_cluster, render
from vgraph.errors import ProcessorError
from vgraph.image import Image
from vgraph.live.evaluator import ProcessorStatus, format_seconds

RETRY_SECONDS = 30.0     # an unreachable cluster is not asked again sooner (each try waits CONNECT_TIMEOUT)
PROGRESS_SECONDS = 0.1   # how often tiles done / total is reported while a frame renders


@dataclass(frozen=True)
class ClusterSetting:
    """Where and how the final frames are rendered: ``address`` as ``--cluster`` takes it."""

    address: str
    split: str = "tiles"
    tiles: tuple[int, int] = (2, 2)

    def describe(self) -> str:
        return f"{self.address} ({self.split}, {self.tiles[0]}x{self.tiles[1]} tiles)"


def image_producers(network, target: str) -> set[str]:
    """The processors ``target`` needs whose outputs are all images (the renderers): what the
    cluster draws. The others (sources, filters: volumes, meshes, numbers) run in the render
    process, so the inspector and the transfer-function editors still get histograms and statuses."""
    needed = {target, *nx.ancestors(network.graph, target)}
    return {pid for pid in needed
            if all(issubclass(port.data_type, Image) for port in network[pid].outports)}


class ClusterRenderer:
    """The render process's connection to a cluster, kept between jobs."""

    def __init__(self):
        self.setting: ClusterSetting | None = None
        self.client = None
        self._stack: contextlib.ExitStack | None = None
        self._failed: tuple[str, float] | None = None  # (address, when) of the last failed connect
        self.workers = 0

    def use(self, setting: ClusterSetting | None, connect: bool = True) -> str | None:
        """Follow the job's setting: connect (if ``connect``: a job that draws there), keep or
        close. A message when the cluster cannot be reached (the frame is then rendered locally),
        once per failed attempt, so the log does not repeat it for every frame."""
        if setting is None or (self.setting is not None and setting.address != self.setting.address):
            self.close()
        if setting is None:
            self._failed = None
            return None
        self.setting = setting
        if self.client is not None or not connect:
            return None
        if self._failed and self._failed[0] == setting.address and \
                time.monotonic() - self._failed[1] < RETRY_SECONDS:
            return None
        if setting.address.startswith("local:"):
            _allow_worker_processes()
        stack = contextlib.ExitStack()
        try:
            self.client = stack.enter_context(connect_cluster(setting.address))
        except Exception as error:  # ClusterError, or anything Dask raises while starting a LocalCluster
            stack.close()
            self._failed = (setting.address, time.monotonic())
            return f"cannot render on cluster {setting.address}: {error}; rendered locally"
        self._stack, self._failed = stack, None
        self.workers = len(self.client.scheduler_info().get("workers", {}))
        return None

    def draw(self, network, target: str, size: tuple[int, int], progress=None) -> np.ndarray:
        """The picture of ``target`` at ``size`` drawn by the cluster, float32 (H, W, 4) as
        Network.evaluate gives it; ``progress(done, total)`` is called while the tiles come in."""
        setting, client = self.setting, self.client
        outcome: dict = {}

        def run():
            try:
                outcome["pixels"] = render(network, client, split=setting.split, tiles=setting.tiles,
                                           size=size, target=target)
            except BaseException as error:  # re-raised in the calling thread
                outcome["error"] = error

        thread = threading.Thread(target=run, name="vgraph-cluster-render", daemon=True)
        thread.start()
        last = None
        while thread.is_alive():
            thread.join(PROGRESS_SECONDS)
            counts = self._counts()
            if progress is not None and counts != last and counts[0]:
                progress(*counts)
                last = counts
        if "error" in outcome:
            raise outcome["error"]
        if progress is not None:  # all in; a frame faster than one report has no count left to read
            total = last[1] if last else setting.tiles[0] * setting.tiles[1]
            progress(total, total)
        return outcome["pixels"]

    def _counts(self) -> tuple[int, int]:
        """(finished, all) futures the client holds: the tasks of the frame in flight."""
        states = list(getattr(self.client, "futures", {}).values())
        # While render() is still submitting, the client holds only some of the tiles' futures.
        expected = self.setting.tiles[0] * self.setting.tiles[1] if self.setting.split == "tiles" else 0
        return sum(state.status == "finished" for state in states), max(len(states), expected)

    def lost(self) -> None:
        """The cluster failed mid-frame: connect again for the next one."""
        self.close()

    def close(self) -> None:
        if self._stack is not None:
            with contextlib.suppress(Exception):  # a cluster already gone must not fail the job
                self._stack.close()
        self._stack = self.client = self.setting = None
        self.workers = 0


def _allow_worker_processes() -> None:
    """Let this process start the LocalCluster's worker processes. The render process is a daemon
    (it must not outlive the window), and multiprocessing refuses children to daemons because it
    would not wait for them; here ``close()`` (on a cleared setting and when the render process
    stops) closes the cluster and its workers, and a worker whose nanny's process was killed
    stops by itself (Dask's workers watch their parent)."""
    process = multiprocessing.current_process()
    if process.daemon:
        process._config["daemon"] = False  # what multiprocessing checks before starting a child


class ClusterView:
    """One job's use of the cluster: the ``draw`` hook ``evaluate_view`` calls for each display,
    and what it did (``drawn``: display -> (processors drawn on the cluster, seconds);
    ``messages``: fallbacks, for the window's log)."""

    def __init__(self, renderer: ClusterRenderer, network, progress=None):
        self.renderer, self.network, self.progress = renderer, network, progress
        self.drawn: dict[str, tuple[set[str], float]] = {}
        self.messages: list[str] = []

    def draw(self, target: str, size: tuple[int, int]) -> np.ndarray | None:
        """The display's picture from the cluster, or None: draw it locally (no cluster, or the
        cluster could not; the reason is in ``messages``)."""
        if self.renderer.client is None:
            return None
        producers = image_producers(self.network, target)
        # The rest runs here, first: its errors are the network's, and it feeds the editors.
        for pid in self.network.graph.predecessors(target):
            self._update_local(pid, producers)
        start = time.perf_counter()
        try:
            pixels = self.renderer.draw(self.network, target, size, self.progress)
        except ProcessorError:
            raise  # a processor failed on a worker: the node shows it, as for a local frame
        except Exception as error:
            self.messages.append(f"cluster {self.renderer.setting.address} could not draw '{target}' "
                                 f"({type(error).__name__}: {error}); rendered locally")
            if not isinstance(error, (ValueError, NotImplementedError)):  # not the network: the connection
                self.renderer.lost()
            return None
        self.drawn[target] = (producers, time.perf_counter() - start)
        return pixels

    def _update_local(self, pid: str, producers: set[str]) -> None:
        if pid in producers:
            for source in self.network.graph.predecessors(pid):
                self._update_local(source, producers)
        else:
            self.network.update(pid)

    def statuses(self, statuses: dict) -> dict:
        """The render process's statuses with the processors the cluster drew marked as such."""
        setting, workers = self.renderer.setting, self.renderer.workers
        for producers, seconds in self.drawn.values():
            for pid in producers:
                if statuses.get(pid) is None or statuses[pid].state != "error":
                    statuses[pid] = ProcessorStatus(
                        "evaluated", f"on cluster, {format_seconds(seconds)}",
                        f"drawn by {workers} worker(s) of {setting.describe()}; the frame took "
                        f"{format_seconds(seconds)}")
        return statuses
