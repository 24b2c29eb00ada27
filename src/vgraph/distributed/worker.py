"""What runs inside a Dask worker process: build the shipped network once, render tiles of it.

- The network travels as its JSON document (text) with the folder its relative paths mean (the
  network file's): volumes are read by the worker from that shared path, never pickled through the
  scheduler.
- Module-level state, per worker process: the networks built so far (keyed by a hash of the
  document without its cameras, folder and target) with their full-view cameras. A second tile, or
  a frame from another view, of the same network on the same worker reuses the built network, so
  its volume is read and uploaded to the GPU once and its bricks stay in the BrickedRayCaster's
  cache (Dask's placement sends a leaves run back to that worker); only the renderers run again for
  the new camera.
- One GL context per worker process: ``vgraph.gl_context.get_context()`` creates the process's
  headless EGL context on the first evaluation in that worker (never in the client or the
  scheduler) and every later task reuses it. GL contexts are not thread-safe, so tasks of one
  worker hold ``GL_LOCK`` while they touch it (workers are started single-threaded anyway); what
  the worker's brick caches read while a task holds it is that task's (report.counted_reads).
"""

from __future__ import annotations

import hashlib
import json
import os
import threading
from collections import OrderedDict
from pathlib import Path

import numpy as np
from tqdm import tqdm

import vgraph
from vgraph import gl_context
from vgraph.distributed.report import counted_reads
from vgraph.distributed.tiles import Tile, cameras, set_tile_cameras
from vgraph.fileformat import build_network, network_document, parse_document

GL_LOCK = threading.Lock()
# The networks this worker process built, by document (worker_network): the process's own state,
# as its GL context is, not data derived from a source object, so not kept by vgraph.derived.
_NETWORKS: OrderedDict[str, tuple] = OrderedDict()  # key -> (network, full cameras)
_KEPT = 2  # networks kept per worker (each may hold a volume on the GPU)
_PREPARED = False  # load_plugins has set this process up


def render_tile(document: str, base_dir: str | None, target: str, size: tuple[int, int],
                tile: Tile, plugins: tuple[str, ...] = ()) -> np.ndarray:
    """The rendered rectangle of ``tile`` (its halo included) of the ``size`` image of ``target``,
    float32 (h, w, 4), row 0 at the top: the task of the tiles split."""
    load_plugins(plugins)
    with GL_LOCK, counted_reads(kept_networks):
        network, full_cameras = worker_network(document, base_dir, target)
        set_tile_cameras(network, full_cameras, tile, size)
        network.update(target, size=tuple(tile.rendered[2:]))
        return np.ascontiguousarray(network.output(target).to_numpy(), dtype=np.float32)


def load_plugins(plugins) -> None:
    """Once per worker process: its own progress-bar lock, and the plug-ins' processor types."""
    global _PREPARED
    if not _PREPARED:
        # tqdm's default lock is a multiprocessing semaphore, registered with the resource
        # tracker this process shares with the client: a worker killed by its nanny (a stalled
        # task) never unregisters it, and the tracker warns about it as `vgraph run` ends. A
        # worker's bars are never shown; a thread lock serves them.
        tqdm.set_lock(threading.RLock())
        _PREPARED = True
    for module in plugins:  # the processor types of a plug-in network (vgraph run --plugin)
        if module not in vgraph.registry.plugins:  # once per worker process
            vgraph.registry.load_plugin(module)


def worker_info() -> dict:
    """Which process this is and what it holds (tests check that contexts are per process and reused)."""
    held = gl_context.has_context()
    return {"pid": os.getpid(), "has_context": held,
            "context_id": id(gl_context.get_context()) if held else None,
            "networks": len(_NETWORKS)}


def kept_networks() -> list:
    """The networks this worker process holds (vgraph.distributed.report counts their caches)."""
    return [network for network, _ in _NETWORKS.values()]


def worker_network(document: str, base_dir: str | None, target: str):
    """The built network of ``document`` with its cameras as the document has them. Networks are
    kept by the document without its cameras: a frame from another view reuses the network (its
    volume, its bricks in the BrickedRayCaster's cache) and only sets the new cameras."""
    scene, views = split_cameras(document)
    key = hashlib.sha256("\0".join((scene, str(base_dir), target)).encode()).hexdigest()
    if key in _NETWORKS:
        _NETWORKS.move_to_end(key)
        network = _NETWORKS[key][0]
        for address, value in views.items():
            network.set(address, value)
        _NETWORKS[key] = (network, cameras(network))
        return _NETWORKS[key]
    network = build(document, base_dir)
    _NETWORKS[key] = (network, cameras(network))
    while len(_NETWORKS) > _KEPT:
        _NETWORKS.popitem(last=False)
    return _NETWORKS[key]


def split_cameras(document: str) -> tuple[str, dict]:
    """(the document without its camera properties, as canonical JSON; 'id.name' -> camera value)."""
    parsed = json.loads(document)
    views = {}
    for entry in parsed.get("processors", []):
        try:
            kinds = vgraph.registry.get(entry.get("type", "")).properties
        except Exception:  # an unknown type: build() reports it
            continue
        properties = entry.get("properties", {})
        for name in [n for n in properties if n in kinds and kinds[n].kind == "camera"]:
            views[f"{entry.get('id')}.{name}"] = properties.pop(name)
    return json.dumps(parsed, sort_keys=True), views


def shipped(network) -> tuple[str, str | None]:
    """(the network's JSON document, the folder its relative paths mean): what a task carries
    (the client packs it here; ``build`` unpacks it in the worker).
    The folder is the network file's, which the workers must see at the same path (a shared
    file system), as they see the volumes and OME-Zarr stores the network reads."""
    # A network built in a script has no folder: its relative paths mean the client's current one.
    base_dir = network.base_dir if network.base_dir is not None else Path.cwd()
    document = network_document(network, base_dir)
    return json.dumps(document), str(base_dir)


def build(document: str, base_dir: str | None):
    """The network of a shipped document (migrated and validated as a file would be)."""
    source = f"<network shipped from {base_dir or 'the client'}>"
    parsed = parse_document(json.loads(document), source)
    return build_network(parsed, source, base_dir=Path(base_dir) if base_dir else None)
