"""The Timeline dock: keyframes of any property (vgraph.tracks), scrubbing and playing them
(issue 37; docs/guide/animation.md), as Voreen's animation editor and ParaView's keyframe editor.

Conventions:
- The property box lists every property of the network as ``id.property``; it follows the
  selection in the network editor (the selected processor's camera, else its first property), and
  can be set by hand. **Add Keyframe** stores the property's current value at the time shown, with
  the easing chosen (replacing a keyframe at the same time); **Remove Keyframe** takes the
  keyframe of that property at that time out. Both are one undo step (``tracks.SetTracks`` through
  ``Workspace.execute``); a keyframe that cannot be interpolated with its neighbours (two transfer
  functions with different numbers of points) is refused, the reason in the status bar.
- The slider is the time, in frames of ``FPS`` per second, up to the end of the tracks (at least
  ``MIN_SECONDS``). Moving it sets every tracked property to its value at that time
  (``tracks.apply_tracks``), so the canvases render the frame `vgraph animate --timeline` renders
  for that time. While the slider is dragged the live evaluation is interactive (coarse frames,
  live_evaluation.INTERACTIVE_SCALE); on release the full frame follows.
- Play steps the time by 1/FPS each 1/FPS seconds to the end and stops there; the render process
  skips frames it cannot keep up with.
- Scrubbing sets properties without undo steps (like moving a time slider in ParaView): the
  keyframes are the document, the properties show a moment of it.
- The list below shows each track and its keyframe times; the window's undo follows it.
- **Export...** renders the tracks through the render process into an MP4, a GIF or PNG frames
  (gui/timeline_export.py), the frames `vgraph animate --timeline` writes.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import (QComboBox, QDockWidget, QDoubleSpinBox, QFileDialog, QHBoxLayout, QLabel,
                               QListWidget, QPushButton, QSlider, QVBoxLayout, QWidget)

from vgraph.errors import VGraphError
from vgraph.gui.layout import log_tab
from vgraph.gui.timeline_export import export_timeline
from vgraph.properties import CameraProperty
from vgraph.tracks import (EASINGS, Keyframe, SetTracks, apply_tracks, check_track, duration,
                           with_keyframe, without_keyframe)

FPS = 30
MIN_SECONDS = 5.0   # the slider's reach with no (or short) tracks: room to place the next keyframe


def property_addresses(network) -> list[str]:
    return [f"{pid}.{name}" for pid, processor in network.processors.items() for name in processor.properties]


class TimelinePanel(QWidget):
    status_message = Signal(str)
    interacting = Signal(bool)   # to LiveEvaluation.interactive: coarse frames while scrubbing

    def __init__(self, workspace, parent=None):
        super().__init__(parent)
        self.workspace, self.network = workspace, None
        self.property_box = QComboBox()
        self.property_box.setSizeAdjustPolicy(QComboBox.AdjustToContents)
        self.property_box.setToolTip("the property a keyframe is added to or removed from")
        self.easing_box = QComboBox()
        self.easing_box.addItems(EASINGS)
        self.easing_box.setToolTip("how the value runs from this keyframe to the next")
        add, remove = QPushButton("Add Keyframe"), QPushButton("Remove Keyframe")
        add.clicked.connect(self.add_keyframe)
        remove.clicked.connect(self.remove_keyframe)
        self.play_button = QPushButton("Play")
        self.play_button.setCheckable(True)
        self.play_button.toggled.connect(self.play)
        self.seconds = QDoubleSpinBox()
        self.seconds.setDecimals(3)
        self.seconds.setSuffix(" s")
        self.seconds.setSingleStep(1.0 / FPS)
        self.seconds.valueChanged.connect(lambda value: self.slider.setValue(round(value * FPS)))
        self.slider = QSlider(Qt.Horizontal)
        self.slider.valueChanged.connect(self._slider_moved)
        self.slider.sliderPressed.connect(lambda: self.interacting.emit(True))
        self.slider.sliderReleased.connect(lambda: self.interacting.emit(False))
        self.track_list = QListWidget()
        self.export_button = QPushButton("Export...")
        self.export_button.setToolTip("render the tracks to an MP4, a GIF or a folder of PNG frames")
        self.main_window = None   # the main window whose canvases an export renders (timeline_dock)
        self.timer = QTimer(self)
        self.timer.setInterval(round(1000 / FPS))
        self.timer.timeout.connect(self._next_frame)
        self._build_layout(add, remove)
        self.scene = None   # the network editor whose selection chooses the property (follow_scene)
        workspace.undo_stack.indexChanged.connect(self._undo_moved)
        workspace.network_replaced.connect(self._follow)
        self._follow(workspace.network)

    def _build_layout(self, add, remove) -> None:
        keys = QHBoxLayout()
        for widget in (QLabel("Property"), self.property_box, self.easing_box, add, remove):
            keys.addWidget(widget)
        keys.addStretch(1)
        time = QHBoxLayout()
        for widget in (self.play_button, self.slider, self.seconds, self.export_button):
            time.addWidget(widget)
        column = QVBoxLayout(self)
        column.addLayout(keys)
        column.addLayout(time)
        column.addWidget(self.track_list)

    # --- following the network ------------------------------------------------------------------
    def _follow(self, network) -> None:
        self.timer.stop()
        if self.network is not None:
            self.network.unsubscribe(self._on_event)
        self.network = network
        network.subscribe(self._on_event)
        self._fill_properties()
        self.refresh()

    def follow_scene(self, scene) -> None:
        self.scene = scene
        scene.selectionChanged.connect(self._selection_changed)

    def detach(self) -> None:
        """Stop following the network, the editor and the undo stack (the window closes)."""
        self.timer.stop()
        if self.network is not None:
            self.network.unsubscribe(self._on_event)
            self.network = None
        if self.scene is not None:
            self.scene.selectionChanged.disconnect(self._selection_changed)
            self.scene = None
            self.workspace.undo_stack.indexChanged.disconnect(self._undo_moved)
            self.workspace.network_replaced.disconnect(self._follow)

    def _undo_moved(self, _index: int) -> None:
        self.refresh()

    def _selection_changed(self) -> None:
        processors, _, _ = self.scene.selection()
        if len(processors) == 1:
            self.choose_processor(processors[0])

    def _on_event(self, event: str, **details) -> None:
        if event in ("processor_added", "processor_removed"):
            self._fill_properties()
            self.refresh()

    def _fill_properties(self) -> None:
        chosen = self.property_box.currentText()
        self.property_box.blockSignals(True)
        self.property_box.clear()
        self.property_box.addItems(property_addresses(self.network))
        self.property_box.setCurrentText(chosen)
        self.property_box.blockSignals(False)

    def choose_processor(self, processor_id: str | None) -> None:
        """The selected processor's camera, else its first property, becomes the chosen one."""
        if processor_id is None or processor_id not in self.network:
            return
        processor = self.network[processor_id]
        names = [n for n, p in processor.properties.items() if isinstance(p, CameraProperty)] \
            or list(processor.properties)
        if names:
            self.property_box.setCurrentText(f"{processor_id}.{names[0]}")

    def refresh(self) -> None:
        """The slider's reach and the list of tracks, after any change of the tracks."""
        end = max(duration(self.network.tracks), MIN_SECONDS, self.time())
        self.slider.blockSignals(True)
        self.slider.setRange(0, round(end * FPS))
        self.slider.blockSignals(False)
        self.seconds.blockSignals(True)
        self.seconds.setRange(0.0, end)
        self.seconds.blockSignals(False)
        self.track_list.clear()
        for track in self.network.tracks:
            times = ", ".join(f"{k.time:g} s ({k.easing})" for k in track.keyframes)
            gone = "" if track.address.split(".")[0] in self.network else " (processor removed: not saved)"
            self.track_list.addItem(f"{track.address}: {times}{gone}")

    # --- time -----------------------------------------------------------------------------------
    def time(self) -> float:
        return self.slider.value() / FPS

    def scrub(self, seconds: float) -> None:
        """Show the moment ``seconds``: every tracked property set to its value then."""
        self.slider.setValue(round(seconds * FPS))

    def _slider_moved(self, frame: int) -> None:
        seconds = frame / FPS
        self.seconds.blockSignals(True)
        self.seconds.setValue(seconds)
        self.seconds.blockSignals(False)
        try:
            apply_tracks(self.network, self.network.tracks, seconds)
        except VGraphError as error:  # a track whose processor was removed since
            self.status_message.emit(f"Timeline: {error}")

    def play(self, on: bool) -> None:
        if on:
            if self.slider.value() >= round(duration(self.network.tracks) * FPS):
                self.scrub(0.0)   # from the start again
            self.timer.start()
        else:
            self.timer.stop()
        self.play_button.setText("Pause" if on else "Play")

    def _next_frame(self) -> None:
        end = round(duration(self.network.tracks) * FPS)
        if self.slider.value() >= end:
            self.play_button.setChecked(False)
            return
        self.slider.setValue(self.slider.value() + 1)

    # --- export ---------------------------------------------------------------------------------
    def ask_export_path(self) -> str:
        path, _ = QFileDialog.getSaveFileName(self, "Export Timeline", "animation.mp4",
                                              "Video (*.mp4 *.gif);;PNG frames (*)")
        return path

    def export(self, path: str | None = None, fps: float = FPS) -> int:
        """Render the tracks into ``path`` (asked if None), ``fps`` frames a second; the number of
        frames, 0 if none."""
        path = path or self.ask_export_path()
        if not path:
            return 0
        start = self.time()
        report = lambda done, total: self.status_message.emit(f"Exporting {path}: frame {done} of {total}")
        try:
            count = export_timeline(self.main_window, path, fps, progress=report)
        except VGraphError as error:
            self.status_message.emit(f"Cannot export: {error}")
            return 0
        finally:
            self.scrub(start)
            self._slider_moved(self.slider.value())  # the properties of the time shown again
        self.status_message.emit(f"Exported {count} frames to {path}")
        return count

    # --- keyframes ------------------------------------------------------------------------------
    def add_keyframe(self) -> bool:
        """A keyframe of the chosen property's current value at the time shown (one undo step)."""
        address = self.property_box.currentText()
        try:
            keyframe = Keyframe(self.time(), self.network.get(address), self.easing_box.currentText())
            tracks = with_keyframe(self.network.tracks, address, keyframe)
            check_track(next(t for t in tracks if t.address == address), self.network._property(address))
            self.workspace.execute(SetTracks.of(self.network, tracks, f"Add keyframe {address} at "
                                                                      f"{keyframe.time:g} s"))
        except VGraphError as error:
            self.status_message.emit(f"Cannot add the keyframe: {error}")
            return False
        return True

    def remove_keyframe(self) -> bool:
        address, time = self.property_box.currentText(), self.time()
        tracks = without_keyframe(self.network.tracks, address, time)
        if tracks == tuple(self.network.tracks):
            self.status_message.emit(f"{address} has no keyframe at {time:g} s")
            return False
        self.workspace.execute(SetTracks.of(self.network, tracks, f"Remove keyframe {address} at {time:g} s"))
        return True


def timeline_dock(window) -> QDockWidget:
    """The dock, tabbed with the Log and hidden (View > Timeline shows it); it follows the network
    editor's selection and scrubs with coarse frames."""
    panel = TimelinePanel(window.workspace)
    dock = log_tab(window, "Timeline", panel)
    panel.interacting.connect(window.evaluation.interactive)
    panel.follow_scene(window.scene)
    panel.main_window = window
    panel.export_button.clicked.connect(lambda: panel.export())
    return dock
