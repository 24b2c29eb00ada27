"""What a task reports it read (vgraph.distributed.report.measured) when several networks share a
worker process: each task only its own network's reads, also while another task of that worker
runs in another thread (a worker with several threads, now refused by render_report, ran a
composite beside a run). The tasks run in this process, as
tests/test_distributed.py's shipped_tiles does: a task on a worker is the same function."""

from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np
import pytest

from vgraph.distributed import worker
from vgraph.distributed.render import prepare
from vgraph.distributed.report import measured
from vgraph.network import Network
from vgraph.transfer_function import TransferFunction

SIZE = (40, 32)
TF = TransferFunction(points=[(0.0, 1, 1, 1, 0.0), (1.0, 1, 0.6, 0.2, 0.8)])


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """Two OME-Zarr stores of 8^3 leaves, a ball of 26 x 22 x 29 voxels and one of 14 x 12 x 15:
    different bytes to read."""
    from vgraph.io.convert import convert
    folder = tmp_path_factory.mktemp("report_stores")
    for name, shape in (("big", (26, 22, 29)), ("small", (14, 12, 15))):
        z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in shape], indexing="ij")
        np.save(folder / f"{name}.npy", np.clip(1.0 - np.sqrt(x * x + y * y + z * z), 0, 1).astype(np.float32))
        convert(folder / f"{name}.npy", folder / f"{name}.zarr", brick=8, progress=False)
    return folder


@pytest.fixture
def fresh_worker(monkeypatch):
    """This process as a worker that holds no network yet (its networks are module state)."""
    monkeypatch.setattr(worker, "_NETWORKS", OrderedDict())


def sweep_network(folder, name) -> Network:
    net = Network(base_dir=folder)
    net.add("VolumeSource", id="src", path=f"{name}.zarr")
    net.add("SweepPlaneRenderer", id="sweep", early_termination=1.0, transfer_function=TF)
    net.connect("src.volume", "sweep.volume")
    return net


def whole_tile(net):
    """(the task's arguments to render the whole SIZE picture of ``net`` as one tile)."""
    plan = prepare(net, tiles=(1, 1), size=SIZE, target="sweep.image")
    document, base_dir = worker.shipped(net)
    return (document, base_dir, plan.target, plan.size, plan.tiles[0])


def read_alone(net) -> int:
    """The bytes one process reads for the picture (a network of its own)."""
    net.evaluate("sweep.image", size=SIZE)
    return net["sweep"].last_sweep["bytes_read"]


def test_two_networks_on_one_worker_each_report_their_own_reads(stores, fresh_worker):
    big, small = (sweep_network(stores, name) for name in ("big", "small"))
    alone = {"big": read_alone(sweep_network(stores, "big")), "small": read_alone(sweep_network(stores, "small"))}
    assert 0 < alone["small"] < alone["big"]
    _, first = measured(worker.render_tile, *whole_tile(big))
    _, second = measured(worker.render_tile, *whole_tile(small))
    assert len(worker.kept_networks()) == 2  # both held by the worker, with their caches
    assert first["bytes_read"] == alone["big"] and second["bytes_read"] == alone["small"]
    _, again = measured(worker.render_tile, *whole_tile(big))
    assert again["bytes_read"] == 0  # the worker kept the big network's leaves


def test_a_task_does_not_report_what_another_task_of_its_worker_read_meanwhile(stores, fresh_worker):
    """A task that reads nothing (a composite of the leaves split) runs in one thread while a task
    of a network reads its leaves in another; each reports only its own reads."""
    running, finish = threading.Event(), threading.Event()
    reports = {}

    def composite_like():
        running.set()
        assert finish.wait(60)
        return "composited"

    def beside():
        reports["composite"] = measured(composite_like)[1]

    thread = threading.Thread(target=beside)
    thread.start()
    try:
        assert running.wait(60)
        # GL work stays in this thread (the process's GL context is current here).
        _, reports["render"] = measured(worker.render_tile, *whole_tile(sweep_network(stores, "big")))
    finally:
        finish.set()
        thread.join(60)
    assert reports["render"]["bytes_read"] == read_alone(sweep_network(stores, "big")) > 0
    assert reports["composite"]["bytes_read"] == 0 and reports["composite"]["bricks_read"] == 0
