"""A source that takes as long as a test wants, reporting its steps (tests/test_gui_progress.py).

``SlowSource`` is the FunctionSelector with a ``gate``: half-way through its ``steps`` it waits
until the file ``gate`` names exists (at most ``GATE_TIMEOUT`` seconds), so a test sees it running
for as long as it needs, without sleeping for a guessed time. The render process imports it by
module name, as it imports any plug-in.
"""

import time
from pathlib import Path

from vgraph import IntProperty, StringProperty, VGraphError
from vgraph.processors.function_selector import FunctionSelector

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
