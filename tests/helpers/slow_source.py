"""A source that takes as long as a test wants, reporting its steps (tests/test_gui_progress.py).

``SlowSource`` is the FunctionSelector with a ``gate``: half-way through its ``steps`` it waits
until the file ``gate`` names exists (at most ``GATE_TIMEOUT`` seconds), so a test sees it running
for as long as it needs, without sleeping for a guessed time. The render process imports it by
module name, as it imports any plug-in.
"""

import json
import time
from pathlib import Path

import pytest

import vgraph
from helpers.paths import REPO
from vgraph import IntProperty, StringProperty, VGraphError
from vgraph.processors.function_selector import FunctionSelector
from vgraph.registry import registry

GATE_TIMEOUT = 60.0


class SlowSource(FunctionSelector):
    """Test source: reports ``steps`` steps and waits for its gate file half-way."""
    category = "Test"
    gate = StringProperty("", doc="a file that must exist before the second half of the steps")
    steps = IntProperty(10, min=2, max=1000)

    def process(self):
        for step in range(self.steps):
            self.report_progress(step, self.steps, "loading")
            if step == self.steps // 2 and self.gate:
                self.report_progress(step, self.steps, "waiting for the gate")
                self._wait_for_gate()
        self.report_progress(self.steps, self.steps, "loading")
        return super().process()

    def _wait_for_gate(self) -> None:
        deadline = time.monotonic() + GATE_TIMEOUT
        while not Path(self.gate).exists():
            if time.monotonic() > deadline:
                raise VGraphError(f"{self.id}: gate {self.gate} did not open")
            time.sleep(0.01)


@pytest.fixture
def slow_source():
    """SlowSource known to the window's process for one test only: registered for good it would
    show in every later test's palette (and match searches for its base type)."""
    vgraph.register(SlowSource)
    yield SlowSource
    registry.types.pop(SlowSource.type_name, None)


def slow_network(tmp_path, gate):
    """raycast_sphere.json with its FunctionSelector replaced by a SlowSource held by ``gate``."""
    document = json.loads((REPO / "networks" / "raycast_sphere.json").read_text())
    for processor in document["processors"]:
        if processor["id"] == "source":
            processor["type"] = "SlowSource"
            processor["properties"].update(gate=str(gate), steps=10, resolution=32)
        if processor["id"] == "canvas":
            processor["properties"]["size"] = [64, 64]
    path = tmp_path / "slow.json"
    path.write_text(json.dumps(document))
    return path
