"""What the window shows while an evaluation takes longer than a moment.

The render process says which processor runs and how far its steps are
(``LiveEvaluation.running``, a ``vgraph.progress.Progress``). Once the job in flight has run
``SHOW_AFTER_SECONDS`` (so that a fast frame, or a drag's stream of coarse frames, does not make
anything flicker), the window shows:

- in the status bar: which processor runs and what it does ("source (VolumeSource): reading
  head.raw"), and a progress bar when that work has steps (reading a file, prefiltering,
  bricks); only the label for work without steps;
- on the node: the running state (its own colour, the step and percentage as the status line);
  the nodes downstream of it as waiting for it (they run again after it; before, they stayed
  green, as if nothing were happening);
- on each canvas that shows an older frame: a note that the frame is being updated ("updating:
  source 45%"; the old frame stays up: a blank canvas for every long load would be worse).

All of it goes when the job is answered (its frames and statuses replace it) or cancelled.
"""

from __future__ import annotations

import networkx as nx
from PySide6.QtCore import QObject, QTimer
from PySide6.QtWidgets import QLabel, QProgressBar

from vgraph.live.evaluator import running_status, waiting_status

SHOW_AFTER_SECONDS = 0.3
STALE_PREFIX = "updating: "   # the canvas note; a note of another kind is never touched


class EvaluationProgress(QObject):
    """The window's display of the job in flight (module docstring): ``label`` and ``bar`` in the
    status bar, the nodes it marks, the canvases' notes."""

    def __init__(self, window):
        super().__init__(window)
        self.window = window
        self.evaluation = window.evaluation
        self.label = QLabel()
        self.label.setObjectName("running_processor")
        self.bar = QProgressBar()
        self.bar.setObjectName("running_progress")
        self.bar.setRange(0, 1000)
        self.bar.setMaximumWidth(160)
        self.bar.setTextVisible(True)
        status_bar = window.statusBar()
        status_bar.addPermanentWidget(self.label)
        status_bar.addPermanentWidget(self.bar)
        self.label.hide()
        self.bar.hide()
        self.current = None          # the last Progress received
        self.marked: set[str] = set()   # the nodes drawn as running or waiting
        self.timer = QTimer(self)    # shows a progress that arrived before the delay was over
        self.timer.setSingleShot(True)
        self.timer.timeout.connect(self._show)
        self.evaluation.running.connect(self.update_progress)
        self.evaluation.busy_changed.connect(self._busy_changed)
        self.evaluation.finished.connect(lambda _outcome: self.clear())

    @property
    def visible(self) -> bool:
        return self.label.isVisible()

    def update_progress(self, progress) -> None:
        self.current = progress
        if progress is None:
            self.clear()
            return
        waited = self.evaluation.renderer.elapsed()
        if waited >= SHOW_AFTER_SECONDS:
            self._show()
        elif not self.timer.isActive():
            self.timer.start(max(1, int((SHOW_AFTER_SECONDS - waited) * 1000)))

    def _show(self) -> None:
        progress = self.current
        if progress is None or not self.evaluation.renderer.busy:
            return
        self.label.setText(f"running {progress.describe()}" if progress.processor else progress.describe())
        self.label.show()
        fraction = progress.fraction
        if fraction is None:
            self.bar.hide()
        else:
            self.bar.setValue(round(fraction * 1000))
            self.bar.setFormat(f"{fraction * 100:.0f}%")
            self.bar.show()
        self._mark_nodes(progress)
        note = STALE_PREFIX + (progress.processor or "finishing") + (
            f" {fraction * 100:.0f}%" if fraction is not None else "")
        for view in self.window.canvases.views.values():  # short: a canvas dock is often narrow
            if view.frame() is not None and (not view.message() or view.message().startswith(STALE_PREFIX)):
                view.set_message(note)

    def _mark_nodes(self, progress) -> None:
        """The running node as running, the nodes downstream of it as waiting (they run again
        after it); nodes marked before and no longer meant get their last status back."""
        network = self.window.workspace.network
        marks = {}
        if progress.processor in network:
            marks = {pid: waiting_status(progress.processor)
                     for pid in nx.descendants(network.graph, progress.processor)}
            marks[progress.processor] = running_status(progress)
        for pid in set(self.marked) - set(marks):
            self._restore_node(pid)
        for pid, status in marks.items():
            node = self.window.scene.nodes.get(pid)
            if node is not None:
                node.set_status(status)
        self.marked = set(marks)

    def _restore_node(self, pid: str) -> None:
        node = self.window.scene.nodes.get(pid)
        if node is not None and pid in self.window.workspace.network:
            node.set_status(self.evaluation.status_of(pid))

    def clear(self) -> None:
        """Nothing runs (any more): hide the bar, give the node and the canvases back."""
        self.timer.stop()
        self.label.hide()
        self.bar.hide()
        for pid in self.marked:
            self._restore_node(pid)
        self.marked = set()
        for view in self.window.canvases.views.values():
            if view.message().startswith(STALE_PREFIX):
                view.set_message("")

    def _busy_changed(self, busy: bool) -> None:
        if not busy:
            self.current = None
            self.clear()
