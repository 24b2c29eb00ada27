"""One dock with a ``CanvasView`` per display processor (a Canvas), following the network.

Conventions:
- A display gets its dock when it is added (or a network is opened) and loses it when removed;
  docks of one window are tabbed together, titled "Canvas: <id>", below the palette
  (``layout.place_canvas``).
- Frames from the render process go to the view of their display; a display that failed or is not
  ready shows why instead.
- A drag on any canvas makes the evaluation interactive (reduced resolution) until it ends.
- Each dock shows a ``CanvasPane``: the canvas toolbar (canvas_toolbar.py) above the view. A frame
  comes with the camera and box it was rendered with (the same render result's ``view_cameras``
  and ``view_boxes``, for the camera the view edits), for the overlays.
- The *current* canvas (File > Export Image's) is the one last clicked into or brought to front,
  else the first one.
"""

from __future__ import annotations

from PySide6.QtCore import QObject, Signal
from PySide6.QtWidgets import QDockWidget, QMainWindow

from vgraph.gui import layout
from vgraph.gui.canvas_toolbar import CanvasPane
from vgraph.gui.canvas_view import CanvasView, camera_property_for
from vgraph.gui.hover import HoverReadout
from vgraph.gui.markup_placing import MarkupPlacer
from vgraph.live.evaluator import EvaluationOutcome, is_display
from vgraph.gui.live_evaluation import LiveEvaluation
from vgraph.gui.overlays import ViewGeometry
from vgraph.gui.workspace import Workspace
from vgraph.network import Network


class CanvasDocks(QObject):
    problem = Signal(str)  # a canvas could not do what was asked (e.g. save its image)
    # A canvas was added to or removed from the network one at a time (not when a whole network is
    # opened: Workspace.network_replaced says that), so a layout can re-tile its canvases.
    docks_changed = Signal()

    def __init__(self, window: QMainWindow, workspace: Workspace, evaluation: LiveEvaluation):
        super().__init__(window)
        self.window, self.workspace, self.evaluation = window, workspace, evaluation
        self.network: Network | None = None
        self.docks: dict[str, QDockWidget] = {}
        self.views: dict[str, CanvasView] = {}
        self.current_id: str | None = None
        self._result = None   # the render result whose frames arrive next (view cameras and boxes)
        self.hover = HoverReadout(window, evaluation)  # what lies under the mouse (hover.py)
        self.placer = MarkupPlacer(window, workspace, self.hover)  # markups by mouse (markup_placing.py)
        evaluation.received.connect(self._received)
        evaluation.frames.connect(self.show_frames)
        evaluation.finished.connect(self.show_problems)
        evaluation.busy_changed.connect(self._busy)
        workspace.network_replaced.connect(self._follow)
        self._follow(workspace.network)

    def _follow(self, network: Network) -> None:
        self.detach()
        for processor_id in list(self.docks):
            self._remove(processor_id)
        self.network = network
        network.subscribe(self._on_event)
        for processor in network.processors.values():
            if is_display(type(processor)):
                self._add(processor.id)

    def detach(self) -> None:
        if self.network is not None:
            self.network.unsubscribe(self._on_event)

    def _on_event(self, event: str, **details) -> None:
        if event == "processor_added" and is_display(type(details["processor"])):
            self._add(details["processor"].id)
            self.docks_changed.emit()
        elif event == "processor_removed" and details["processor"].id in self.docks:
            self._remove(details["processor"].id)
            self.docks_changed.emit()

    def _add(self, processor_id: str) -> None:
        view = CanvasView(self.workspace, processor_id, view_cameras=lambda: self.evaluation.view_cameras)
        view.interacting.connect(self.evaluation.interactive)
        view.problem.connect(self.problem)
        view.activated.connect(self._make_current)
        self.hover.watch(view)
        view.placer = self.placer
        view.set_message("waiting for the render process")
        dock = QDockWidget(f"Canvas: {processor_id}", self.window)
        dock.setObjectName(f"canvas:{processor_id}")
        dock.setWidget(CanvasPane(view, self.workspace.settings))
        dock.visibilityChanged.connect(lambda shown, pid=processor_id: shown and self._make_current(pid))
        layout.place_canvas(self.window, dock, list(self.docks.values()))
        dock.show()  # a dock added to a window already shown stays hidden otherwise
        dock.raise_()
        self.docks[processor_id], self.views[processor_id] = dock, view

    def _remove(self, processor_id: str) -> None:
        dock = self.docks.pop(processor_id)
        self.views.pop(processor_id)
        if self.current_id == processor_id:
            self.current_id = None
        self.window.removeDockWidget(dock)
        dock.deleteLater()

    def _make_current(self, processor_id: str) -> None:
        if processor_id in self.views:
            self.current_id = processor_id

    def current_view(self) -> CanvasView | None:
        """The canvas last clicked into or brought to front (else the first), or None."""
        if self.current_id in self.views:
            return self.views[self.current_id]
        return next(iter(self.views.values()), None)

    def _received(self, result) -> None:
        self._result = result

    def view_geometry(self, processor_id: str) -> ViewGeometry | None:
        """The camera and box of the frames that are arriving, for the camera ``processor_id``'s
        view edits (None if that processor reported none)."""
        address = camera_property_for(self.workspace.network, processor_id)
        result = self._result
        if address is None or result is None:
            return None
        camera, box = result.view_cameras.get(address), getattr(result, "view_boxes", {}).get(address)
        return None if camera is None or box is None else ViewGeometry(camera, *box)

    def show_frames(self, frames: dict, final: bool) -> None:
        for processor_id, frame in frames.items():
            if processor_id in self.views:
                self.views[processor_id].set_view_geometry(self.view_geometry(processor_id))
                self.views[processor_id].show_frame(frame, final)
                self.views[processor_id].set_message("" if final else "refining...")

    def show_problems(self, outcome: EvaluationOutcome) -> None:
        for processor_id, view in self.views.items():
            if processor_id in outcome.frames:
                continue
            status = self.evaluation.status_of(processor_id)
            if status.state in ("error", "not_ready"):
                view.set_message(status.detail)
            elif processor_id in outcome.not_ready:
                view.set_message("not rendered: a required inport upstream is not connected")
            else:
                view.set_message(f"not rendered: {', '.join(outcome.failed) or 'nothing'} failed upstream")

    def _busy(self, busy: bool) -> None:
        if busy:
            for view in self.views.values():
                if view.frame() is None:
                    view.set_message("rendering...")
