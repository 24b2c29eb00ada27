"""The property inspector: the selected processor's properties as editors (see ``editors.py``).

Conventions:
- Editors are generated from the property declarations; editors and labels carry the property's
  doc, range or choices and default as a tooltip (``property_tooltip``), labels a mark when the
  property is linked.
- Under the status line, how long the processor takes: while it runs (once the job has run
  ``progress_view.SHOW_AFTER_SECONDS``, so a drag's fast frames do not flicker) "running: <what>
  45%", from ``LiveEvaluation.running``; after, "took 120.0 ms (38 % of the frame)": its last
  run's time (``ProcessorStatus.seconds``) against the whole job's (``RenderResult.seconds``, what
  the status bar says), or "when it last ran" if the last frame reused its output.
- Under that: what the processor produced (``ProcessorStatus.data``: a volume's
  dimensions, type, spacing and value range, a source's file size), as the render process reports it.
- Editors that show what the last frame resolved (the camera editor's automatic near/far) get
  the frame's concrete cameras (``LiveEvaluation.view_cameras``) with every frame.
- Edits go through the workspace (one undo command each; slider drags merge). A rejected value
  is reported through ``status_message`` and the editor shows the current value again.
- ``interacting`` says when a drag in an editor (a slider, a TF point) starts and ends; editors
  replaced mid-drag (another processor selected) end it.
- The inspector follows the network's events: a value changed elsewhere (undo, a link, a script)
  is shown at once; the status line follows evaluations.
"""

from __future__ import annotations

from PySide6.QtCore import QTimer, Qt, Signal
from PySide6.QtWidgets import QFormLayout, QLabel, QScrollArea, QVBoxLayout, QWidget

from vgraph.errors import VGraphError
from vgraph.gui import transfer_function_editor  # noqa: F401  (registers the TF editor)
from vgraph.gui import gradient_opacity_editor  # noqa: F401  (registers the gradient-opacity editor)
from vgraph.gui import transfer_function_2d_editor  # noqa: F401  (registers the 2D TF editor)
from vgraph.gui import clip_planes_editor  # noqa: F401  (registers the clip-planes editor)
from vgraph.gui import label_table_editor  # noqa: F401  (registers the label-table editor)
from vgraph.gui import markups_editor  # noqa: F401  (registers the markups editor)
from vgraph.gui import camera_editor  # noqa: F401  (registers the camera editor)
from vgraph.gui.editors import PropertyEditor, editor_for
from vgraph.live.evaluator import ProcessorStatus, format_seconds, processor_status
from vgraph.gui.progress_view import SHOW_AFTER_SECONDS
from vgraph.gui.workspace import Workspace
from vgraph.network import Network

LINK_MARK = " \u2194"  # a two-headed arrow after the label of a linked property


def property_tooltip(prop) -> str:
    """The declaration's doc, its range or choices and its default: what a user hovering over an
    editor wants to know before changing it."""
    lines = [prop.doc] if prop.doc else []
    if getattr(prop, "choices", None):
        lines.append("choices: " + ", ".join(str(c) for c in prop.choices))
    low, high = getattr(prop, "min", None), getattr(prop, "max", None)
    if low is not None or high is not None:
        lines.append(f"range: {'-' if low is None else f'{low:g}'} to {'-' if high is None else f'{high:g}'}")
    if isinstance(prop.default, (bool, int, float, str)) and prop.default != "":
        lines.append(f"default: {prop.default}")
    return "\n".join(lines)


def running_text(progress) -> str:
    """The timing line while the processor runs: 'running: reading head.raw 45%'."""
    fraction = progress.fraction
    share = f"{fraction * 100:.0f}%" if fraction is not None else ""
    what = " ".join(part for part in (progress.what, share) if part)
    return f"running: {what}" if what else "running now"


def timing_text(status: ProcessorStatus, ran_last_frame: bool, frame_seconds: float | None) -> str:
    """The timing line after a run: its time and its share of the frame it ran in."""
    if status.seconds is None:
        return ""
    took = f"took {format_seconds(status.seconds)}"
    if not ran_last_frame:
        return f"{took} when it last ran (the last frame reused its output)"
    if frame_seconds:  # the processors' times are parts of the job's, which also sends the frame
        return f"{took} ({min(100.0, 100.0 * status.seconds / frame_seconds):.0f} % of the frame)"
    return took


class PropertyInspector(QWidget):
    status_message = Signal(str)
    interacting = Signal(bool)

    def __init__(self, workspace: Workspace, parent=None, status_of=None, evaluation=None):
        super().__init__(parent)
        self.workspace = workspace
        self.status_of = status_of or (lambda pid: processor_status(self.network, self.network[pid]))
        self.histograms: dict = {}
        self.value_scales: dict = {}
        self.network: Network | None = None
        self.processor_id: str | None = None
        self.editors: dict[str, PropertyEditor] = {}
        self._dragging = False
        self.labels: dict[str, QLabel] = {}
        self.title = QLabel()
        self.title.setTextFormat(Qt.RichText)
        self.title.setWordWrap(True)
        self.status = QLabel()
        self.status.setWordWrap(True)
        self.status.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.timing = QLabel()   # running now, or the last run's time and share of the frame
        self.timing.setObjectName("processor_timing")
        self.evaluation = None       # the LiveEvaluation whose progress and frames the timing follows
        self.frame_seconds: float | None = None  # the whole job of the last frame shown
        self.ran_last_frame: set[str] | None = None  # None: no frame known (every run counts as the last)
        self.running = None          # the Progress of the selected processor, while it runs
        self.running_timer = QTimer(self)   # shows a report that came before the delay was over
        self.running_timer.setSingleShot(True)
        self.running_timer.timeout.connect(self._show_timing)
        self.data = QLabel()   # what the processor produced (dims, type, ...), from the render process
        self.data.setWordWrap(True)
        self.data.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.form_host = QWidget()
        self.form = QFormLayout(self.form_host)
        scroll = QScrollArea()
        scroll.setWidgetResizable(True)
        scroll.setWidget(self.form_host)
        layout = QVBoxLayout(self)
        layout.addWidget(self.title)
        layout.addWidget(self.status)
        layout.addWidget(self.timing)
        layout.addWidget(self.data)
        layout.addWidget(scroll, 1)
        workspace.network_replaced.connect(self._follow)
        self._follow(workspace.network)
        # The window passes LiveEvaluation.status_of; its evaluation is the one to follow.
        evaluation = evaluation if evaluation is not None else getattr(status_of, "__self__", None)
        if hasattr(evaluation, "running") and hasattr(evaluation, "finished"):
            self.attach(evaluation)

    def attach(self, evaluation) -> None:
        """Follow ``evaluation`` (a LiveEvaluation): its running processor and its frames' times."""
        self.evaluation = evaluation
        evaluation.running.connect(self._progress)
        evaluation.finished.connect(self._frame_finished)

    def _follow(self, network: Network) -> None:
        self.detach()
        self.network = network
        network.subscribe(self._on_event)
        self.show_processor(None)

    def detach(self) -> None:
        if self.network is not None:
            self.network.unsubscribe(self._on_event)

    # --- showing --------------------------------------------------------------------------------
    def show_processor(self, processor_id: str | None) -> None:
        self.processor_id = processor_id if processor_id in (self.network or {}) else None
        self._set_dragging(False)
        while self.form.rowCount():
            self.form.removeRow(0)
        self.editors.clear(), self.labels.clear()
        if self.processor_id is None:
            self.title.setText("<i>Select one processor to edit its properties.</i>")
            self.status.clear(), self.data.clear(), self.data.hide()
            self.running = None
            self._show_timing()
            return
        processor = self.network[self.processor_id]
        self.title.setText(f"<b>{processor.id}</b> ({processor.type_name})<br><small>"
                           f"{processor.description}</small>")
        for name, prop in processor.properties.items():
            editor = editor_for(prop, processor)
            editor.edited.connect(lambda value, merge, name=name: self.edit(name, value, merge))
            editor.problem.connect(self.status_message)
            editor.interacting.connect(self._set_dragging)
            editor.setToolTip(property_tooltip(prop))
            label = QLabel(prop.label)
            self.editors[name], self.labels[name] = editor, label
            self.form.addRow(label, editor)
        self._refresh_links()
        self.refresh_status()
        self.set_histograms(self.histograms)
        self.set_value_scales(self.value_scales)
        self._show_view_cameras()

    def _set_dragging(self, on: bool) -> None:
        if on != self._dragging:
            self._dragging = on
            self.interacting.emit(on)

    def refresh_status(self) -> None:
        if self.processor_id is not None:
            status = self.status_of(self.processor_id)
            self.status.setText(f"{status.state.replace('_', ' ')}: {status.detail}")
            self.data.setText(status.data)
            self.data.setVisible(bool(status.data))
            self._show_timing()
            for name, value in status.in_use:
                if hasattr(self.editors.get(name), "show_in_use"):
                    self.editors[name].show_in_use(value)
            self._hide_inapplicable()

    def _hide_inapplicable(self) -> None:
        """Rows of properties that do not apply (Processor.inapplicable: raw-file settings for a
        file with a header) are hidden."""
        hidden = self.network[self.processor_id].inapplicable()
        for name, editor in self.editors.items():
            self.form.setRowVisible(editor, name not in hidden)

    # --- timing ---------------------------------------------------------------------------------
    def _progress(self, progress) -> None:
        """A report from the render process (None: the job is answered)."""
        mine = progress is not None and progress.processor == self.processor_id
        self.running = progress if mine else None
        if not mine:
            self.running_timer.stop()
            self._show_timing()
            return
        waited = self.evaluation.renderer.elapsed() if self.evaluation is not None else SHOW_AFTER_SECONDS
        if waited >= SHOW_AFTER_SECONDS:
            self._show_timing()
        elif not self.running_timer.isActive():
            self.running_timer.start(max(1, int((SHOW_AFTER_SECONDS - waited) * 1000)))

    def _frame_finished(self, outcome) -> None:
        result = self.evaluation.last_result   # set before ``finished`` is emitted
        self.frame_seconds = result.seconds if result is not None else None
        self.ran_last_frame = set(outcome.ran)
        self.running = None
        self.running_timer.stop()
        self.refresh_status()
        self._show_view_cameras()

    def _show_timing(self) -> None:
        text = ""
        if self.processor_id is not None:
            if self.running is not None and self.running.processor == self.processor_id:
                text = running_text(self.running)
            else:
                ran = self.ran_last_frame is None or self.processor_id in self.ran_last_frame
                text = timing_text(self.status_of(self.processor_id), ran, self.frame_seconds)
        self.timing.setText(text)
        self.timing.setVisible(bool(text))

    def set_histograms(self, histograms: dict) -> None:
        """Histograms of the volumes arriving at processors (from the render process), shown by
        editors that can use one (the transfer-function editor)."""
        self.histograms = histograms
        for name, editor in self.editors.items():  # keyed by property: each TF its own volume's
            if hasattr(editor, "set_histogram"):
                editor.set_histogram(histograms.get(f"{self.processor_id}.{name}"))

    def set_value_scales(self, scales: dict) -> None:
        """Value scales of the same volumes, for TFs in data units or percentiles."""
        self.value_scales = scales
        for name, editor in self.editors.items():
            if hasattr(editor, "set_value_scale"):
                editor.set_value_scale(scales.get(f"{self.processor_id}.{name}"))

    def _show_view_cameras(self) -> None:
        """The concrete cameras of the last frame to the editors that show them (the camera
        editor's automatic near/far)."""
        cameras = self.evaluation.view_cameras if self.evaluation is not None else {}
        for name, editor in self.editors.items():
            if hasattr(editor, "set_view_camera"):
                editor.set_view_camera(cameras.get(f"{self.processor_id}.{name}"))

    def _refresh_links(self) -> None:
        processor = self.network[self.processor_id]
        for name, label in self.labels.items():
            address = f"{processor.id}.{name}"
            partners = [l.target if l.source == address else l.source for l in self.network.links
                        if address in (l.source, l.target)]
            prop = processor.properties[name]
            label.setText(prop.label + (LINK_MARK if partners else ""))
            tips = [property_tooltip(prop)]
            if partners:
                tips.append("linked with " + ", ".join(partners))
            label.setToolTip("\n".join(t for t in tips if t))

    # --- editing --------------------------------------------------------------------------------
    def edit(self, name: str, value, merge=None) -> None:
        address = f"{self.processor_id}.{name}"
        try:
            self.workspace.set_property(address, value, merge=merge)
        except VGraphError as error:
            self.status_message.emit(str(error))
            self.editors[name].show_value(self.network.get(address))

    def _on_event(self, event: str, **details) -> None:
        if self.processor_id is None:
            return
        if event == "processor_removed" and details["processor"].id == self.processor_id:
            self.show_processor(None)
        elif event == "property_changed":
            editor = self.editors.get(details["name"]) if details["processor"].id == self.processor_id else None
            if editor is not None:
                editor.show_value(details["processor"].property_values[details["name"]])
            self.refresh_status()  # a change upstream invalidates this processor too
        elif event in ("linked", "unlinked"):
            self._refresh_links()
        elif event in ("evaluated", "connected", "disconnected"):
            self.refresh_status()
