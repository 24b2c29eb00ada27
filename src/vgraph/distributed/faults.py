"""Faults for the cluster's fault tests (tests/test_distributed_faults.py) and its fuzz bench
(bench/cluster_faults.py): workers that die, stop or slow down while a frame's task is on them,
and tasks that no worker can finish (docs/guide/distributed.md, "A worker that stops or dies").

- ``FaultPoint`` is a plug-in processor (``--plugin vgraph.distributed.faults``; render's
  ``plugins=``): put between a renderer and the Canvas, it passes the image through in every tile
  task (and in the leaves split's resolve task), and on the way notes that a task is running
  (a file named after the worker's process in ``marker``, for a test outside the client) and then
  sleeps, hangs or kills its own worker process, as ``fault`` says.
- ``inject(client, fault, is_ours)`` waits until a task of a frame (``is_ours(key)``) is on a
  worker and then kills it (SIGKILL), stops it (SIGSTOP: it no longer answers anyone) or slows it
  (a thread of the worker holds the GL lock that every task takes, for ``seconds``; the worker
  still answers), or cancels the task behind the render's back ("cancel": what the scheduler
  did once in the fault bench). Local workers only: the signals go to process ids this machine
  knows.
- ``worker_pids(client)``: each worker's process id, asked of the nannies (a stopped worker
  cannot answer for itself).
"""

from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path

import numpy as np

import vgraph
from vgraph import FloatProperty, Inport, OptionProperty, Outport, Processor, StringProperty
from vgraph.camera import Camera
from vgraph.distributed.worker import GL_LOCK
from vgraph.image import Image
from vgraph.network import Network

FAULTS = ("none", "sleep", "hang", "exit")
INJECTED = ("kill", "stop", "slow", "cancel")


class FaultPoint(Processor):
    """Passes its image through; on the way notes the task in ``marker`` and sleeps ``seconds``
    (sleep), waits ``seconds`` for nothing (hang: a task no worker finishes in time) or kills its
    own worker process (exit)."""

    category = "Test"
    inports = [Inport("image", Image)]
    outports = [Outport("image", Image)]
    fault = OptionProperty("none", choices=list(FAULTS), doc="what happens in each task")
    seconds = FloatProperty(1.0, min=0.0, max=3600.0, doc="how long sleep and hang last")
    marker = StringProperty("", doc="a folder: each run writes <pid>-<n> there first (empty: none)")

    def process(self, image: Image) -> Image:
        if self.marker:
            _mark(Path(self.marker))
        if self.fault in ("sleep", "hang"):
            time.sleep(self.seconds)
        elif self.fault == "exit":
            os.kill(os.getpid(), signal.SIGKILL)
        return image


def _mark(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for n in range(10_000):
        try:
            with open(folder / f"{os.getpid()}-{n}", "x") as marker:
                marker.write(str(os.getpid()))
            return
        except FileExistsError:
            continue


def worker_pids(client) -> dict[str, int]:
    """Worker address -> its process id: asked of the nannies, which answer while their worker is
    stopped; a worker without a nanny is asked itself (it must not be stopped)."""
    def pid_of(dask_worker):  # the Nanny: its WorkerProcess knows the worker's pid
        process = getattr(dask_worker, "process", None)
        return getattr(process, "pid", None)

    workers = client.scheduler_info()["workers"]
    with_nanny = [address for address, info in workers.items() if info.get("nanny")]
    without = [address for address in workers if address not in with_nanny]
    pids = client.run(pid_of, nanny=True, workers=with_nanny) if with_nanny else {}  # by worker address
    pids.update(client.run(os.getpid, workers=without) if without else {})
    return {address: pid for address, pid in pids.items() if pid is not None}


def inject(client, fault: str, is_ours, seconds: float = 60.0, deadline: float = 60.0,
           settle: float = 0.0, done=lambda: False) -> tuple[str, int] | None:
    """Wait (at most ``deadline`` seconds, and while not ``done()``) until a key with
    ``is_ours(key)`` is on a worker, wait ``settle`` seconds more, then apply ``fault`` ("kill",
    "stop" or "slow" for ``seconds``) to that worker. Returns (its address, its process id), or
    None when no such task showed up (the frame was done first)."""
    if fault not in INJECTED:
        raise ValueError(f"fault must be one of {', '.join(INJECTED)}, got {fault!r}")
    end = time.monotonic() + deadline
    while time.monotonic() < end and not done():
        holders = sorted((address, sorted(str(key) for key in keys if is_ours(str(key))))
                         for address, keys in client.processing().items())
        holders = [(address, keys) for address, keys in holders if keys]
        if holders:
            time.sleep(settle)
            pids = worker_pids(client)
            address, keys = holders[0]
            if address not in pids:
                continue  # gone meanwhile: look again
            _apply(client, fault, address, pids[address], seconds, keys[0])
            return address, pids[address]
        time.sleep(0.02)
    return None


def _apply(client, fault: str, address: str, pid: int, seconds: float, key: str) -> None:
    if fault == "kill":
        os.kill(pid, signal.SIGKILL)
    elif fault == "stop":
        os.kill(pid, signal.SIGSTOP)
    elif fault == "slow":
        client.run(_hold_gl_lock, seconds, workers=[address])  # returns once the thread holds on
    else:  # the scheduler drops the task: its future ends cancelled, as the render did not ask
        from distributed import Future  # imported when used: Dask loads only for a cluster
        Future(key, client).cancel()


def _hold_gl_lock(seconds: float) -> None:
    """In a worker: hold the lock every task takes around its GL work for ``seconds`` (from a
    thread of its own, so the worker keeps answering the scheduler: slow, not stopped)."""
    def hold():
        with GL_LOCK:
            time.sleep(seconds)

    threading.Thread(target=hold, name="vgraph-fault-slow", daemon=True).start()


def resume(pids) -> None:
    """SIGCONT to the given process ids that are still there (a stopped worker the frame did not
    need to restart must not outlive the test stopped)."""
    for pid in pids:
        try:
            os.kill(pid, signal.SIGCONT)
        except ProcessLookupError:
            pass


def fault_network(folder, fault: str = "none", seconds: float = 1.0, marker: str = "",
                  shape=(40, 36, 44), brick_size: int = 8):
    """A network both splits can render, with a FaultPoint 'fault' between its BrickedRayCaster
    'rc' and its Canvas: a ball with ripples saved as ``folder``/ball.npy (the workers read it
    there), an oblique view, dvr with Blinn-Phong, a pass per brick. Registers FaultPoint here when it is not yet."""
    if __name__ not in vgraph.registry.plugins:
        vgraph.registry.load_plugin(__name__)
    folder = Path(folder)
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in shape], indexing="ij")
    ball = np.clip(1.0 - np.sqrt(x * x + 1.3 * y * y + z * z), 0, 1) + 0.15 * np.sin(9 * x)
    np.save(folder / "ball.npy", np.clip(ball, 0, 1).astype(np.float32))
    network = Network(base_dir=folder)
    network.add("VolumeSource", id="source", path="ball.npy")
    camera = Camera(position=(0.7, -0.5, 1.0), focus=(0, 0, 0), near=None, far=None, fit_to_data=True)
    network.add("EntryExitPoints", id="eep", camera=camera)
    # passes: the pictures under faults are compared with the single process's bit for bit, which the
    # pass per brick's tiles are (the single pass agrees within float rounding: distributed.md)
    network.add("BrickedRayCaster", id="rc", brick_size=brick_size, lod_bias=-16.0, shading="blinn_phong",
                method="passes")
    network.add("FaultPoint", id="fault", fault=fault, seconds=float(seconds), marker=str(marker))
    network.add("Canvas", id="canvas")
    network.link("eep.camera", "rc.camera")
    for source, target in (("source.volume", "eep.volume"), ("source.volume", "rc.volume"),
                           ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit"),
                           ("rc.image", "fault.image"), ("fault.image", "canvas.image")):
        network.connect(source, target)
    return network
