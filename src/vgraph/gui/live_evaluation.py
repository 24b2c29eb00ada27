"""When the GUI evaluates: shortly after every change to the network (edits apply live).

Changes arriving together (a slider drag, a macro such as a delete) are gathered by a short
single-shot timer and evaluated once. What runs, and where, is the Evaluator's business
(``evaluator.py``). Nothing that goes wrong in an evaluation escapes: processor failures are in the
outcome, anything else is reported through ``crashed`` so the GUI can log it and carry on.
"""

from __future__ import annotations

import traceback

from PySide6.QtCore import QObject, QTimer, Signal

from vgraph.gui.evaluator import EvaluationOutcome, Evaluator
from vgraph.gui.workspace import Workspace
from vgraph.network import Network

TRIGGER_EVENTS = {"processor_added", "processor_removed", "connected", "disconnected",
                  "linked", "unlinked", "property_changed"}
DELAY_MS = 30


class LiveEvaluation(QObject):
    finished = Signal(object)   # an EvaluationOutcome
    crashed = Signal(str)       # an unexpected failure, with its traceback

    def __init__(self, workspace: Workspace, evaluator: Evaluator | None = None, parent=None):
        super().__init__(parent)
        self.workspace = workspace
        self.evaluator = evaluator or Evaluator()
        self.network: Network | None = None
        self.last_outcome: EvaluationOutcome | None = None
        self.timer = QTimer(self)
        self.timer.setSingleShot(True)
        self.timer.setInterval(DELAY_MS)
        self.timer.timeout.connect(self.run)
        workspace.network_replaced.connect(self._follow)
        self._follow(workspace.network)

    def _follow(self, network: Network) -> None:
        self.detach()
        self.network = network
        network.subscribe(self._on_event)
        self.schedule()

    def detach(self) -> None:
        if self.network is not None and self._on_event in self.network.listeners:
            self.network.listeners.remove(self._on_event)
        self.timer.stop()

    def _on_event(self, event: str, **details) -> None:
        if event in TRIGGER_EVENTS:
            self.schedule()

    def schedule(self) -> None:
        self.timer.start()

    def run(self, include_writers: bool = False) -> EvaluationOutcome | None:
        self.timer.stop()
        try:
            outcome = self.evaluator.run(self.network, include_writers=include_writers)
        except Exception:  # a bug somewhere below: show it, keep the GUI alive
            self.crashed.emit(traceback.format_exc())
            return None
        self.last_outcome = outcome
        self.finished.emit(outcome)
        return outcome
