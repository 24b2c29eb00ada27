"""The Markups dock: every markup of the network in one table (issue 36; docs/guide/measuring.md,
"The Markups dock"), apart from the inspector, which shows one processor at a time: 3D Slicer's
Markups module list.

Conventions:
- One row per markup of every Markups processor (every MarkupsProperty but those that follow
  another through a link, as a LineProfile's linked to a ruler does), in network order: the
  processor, the name, the kind, the number of points, the measurement (a ruler's length and a
  closed curve's perimeter in world units followed by the processor's ``units``, an angle in
  degrees; vgraph.markups_drawing.label_text's numbers), the points ("x y z; ...") and visible.
  It follows the network: any change to a markups property (placing, dragging, undo, the
  inspector) shows at once.
- Selecting a row selects the markup: its Markups processor is selected in the network editor (so
  the inspector shows it, and the mouse places into it) and the markup's row in the inspector's
  markups table; ``selected_markup`` says which (address, name).
- Editing the name, the points or the visible box sets the markups property through the
  workspace: one undo step per edit. An edit the model refuses (a ruler with three points, a name
  taken) changes nothing; the reason goes to the status bar and the row shows the markup again.
  Delete removes the selected markups, one undo step per processor.
- Profile (a ruler's row selected) adds a LineProfile fed from that ruler by a property link
  (``markups`` linked, ``ruler`` named; processors/line_profile.py), its volume connected from
  what feeds the Markups node's ``volume`` inport, and a Canvas showing its plot: one undo step.
- Created hidden, tabbed with the Log at the bottom (View > Markups shows it), so the first-run
  and perspective layouts keep their canvas sizes.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import QDockWidget, QHBoxLayout, QPushButton, QTableWidgetItem, QVBoxLayout, QWidget

from vgraph.errors import VGraphError
from vgraph.gui.editors import row_table
from vgraph.gui.layout import log_tab
from vgraph.gui.markups_editor import measured_text, parse_points, points_text
from vgraph.gui.slice_markups import markups_sources
from vgraph.markups import Markup, Markups
from vgraph.properties import MarkupsProperty

COLUMNS = ("processor", "name", "kind", "points", "measured", "coordinates", "visible")
PROCESSOR, NAME, KIND, COUNT, MEASURED, COORDINATES, VISIBLE = range(len(COLUMNS))
ROW_KEY = Qt.UserRole + 1   # (address, name) of the markup a row shows


def markup_rows(network) -> list[tuple[str, Markup, str]]:
    """(markups address, markup, units) of every markup in the network, in order; a markups
    property that follows another through a link (a LineProfile's) is its leader's, listed once."""
    return [(address, markup, units) for address, markups, _colour, units in markups_sources(network)
            for markup in markups.markups]


class MarkupsTable(QWidget):
    """The table and its Delete button; edits go through ``workspace`` (undoable)."""

    status_message = Signal(str)
    markup_selected = Signal(object)   # (address, name) or None
    profiled = Signal(str)             # the id of a LineProfile added by Profile

    def __init__(self, workspace, parent=None):
        super().__init__(parent)
        self.workspace, self.network = workspace, None
        self.table = row_table(COLUMNS, COORDINATES)
        self.table.itemChanged.connect(self._edited)
        self.table.itemSelectionChanged.connect(self._selection_changed)
        remove = QPushButton("Delete")
        remove.setToolTip("remove the selected markups (undoable)")
        remove.clicked.connect(self.delete_selected)
        self.profile = QPushButton("Profile")
        self.profile.setToolTip("a LineProfile along the selected ruler, following it (a property link)")
        self.profile.clicked.connect(self.profile_selected)
        self.profile.setEnabled(False)
        buttons = QHBoxLayout()
        buttons.addWidget(remove)
        buttons.addWidget(self.profile)
        buttons.addStretch(1)
        column = QVBoxLayout(self)
        column.addWidget(self.table)
        column.addLayout(buttons)
        workspace.network_replaced.connect(self._follow)
        self._follow(workspace.network)

    def _follow(self, network) -> None:
        self.detach()
        self.network = network
        network.subscribe(self._on_event)
        self.refresh()

    def detach(self) -> None:
        """Stop following the network (the window closes)."""
        if self.network is not None:
            self.network.unsubscribe(self._on_event)

    def _on_event(self, event: str, **details) -> None:
        if event in ("processor_added", "processor_removed", "linked", "unlinked"):
            self.refresh()
        elif event == "property_changed":
            prop = details["processor"].properties.get(details["name"])
            if isinstance(prop, MarkupsProperty) or details["name"] == "units":
                self.refresh()

    # --- showing --------------------------------------------------------------------------------
    def refresh(self) -> None:
        """Show the network's markups again, keeping the selected markup selected."""
        selected = self.selected_markup()
        self.table.blockSignals(True)
        try:
            rows = markup_rows(self.network)
            self.table.setRowCount(len(rows))
            for row, (address, markup, units) in enumerate(rows):
                self._show_row(row, address, markup, units)
        finally:
            self.table.blockSignals(False)
        if selected is not None:
            self.select(*selected, emit=False)

    def _show_row(self, row: int, address: str, markup: Markup, units: str) -> None:
        measured = measured_text(markup)
        if markup.length is not None and units:
            measured += f" {units}"
        cells = {PROCESSOR: address.split(".")[0], NAME: markup.name, KIND: markup.kind.replace("_", " "),
                 COUNT: str(len(markup.points)), MEASURED: measured, COORDINATES: points_text(markup)}
        for col, text in cells.items():
            item = QTableWidgetItem(text)
            if col not in (NAME, COORDINATES):
                item.setFlags(item.flags() & ~Qt.ItemIsEditable)
            item.setData(ROW_KEY, (address, markup.name))
            self.table.setItem(row, col, item)
        visible = QTableWidgetItem()
        visible.setFlags((visible.flags() | Qt.ItemIsUserCheckable) & ~Qt.ItemIsEditable)
        visible.setCheckState(Qt.Checked if markup.visible else Qt.Unchecked)
        visible.setData(ROW_KEY, (address, markup.name))
        self.table.setItem(row, VISIBLE, visible)

    # --- selecting ------------------------------------------------------------------------------
    def selected_markup(self) -> tuple[str, str] | None:
        rows = sorted({index.row() for index in self.table.selectionModel().selectedRows()})
        return self._key(rows[0]) if rows else None

    def _key(self, row: int) -> tuple[str, str]:
        return tuple(self.table.item(row, NAME).data(ROW_KEY))

    def select(self, address: str, name: str, emit: bool = True) -> bool:
        """Select the row of markup ``name`` of ``address``; False if there is none."""
        for row in range(self.table.rowCount()):
            if self._key(row) == (address, name):
                if not emit:
                    self.table.blockSignals(True)
                self.table.selectRow(row)
                self.table.blockSignals(False)
                return True
        return False

    def _selection_changed(self) -> None:
        key = self.selected_markup()
        self.profile.setEnabled(key is not None and self._kind(*key) == "ruler")
        self.markup_selected.emit(key)

    def _kind(self, address: str, name: str) -> str | None:
        markups = self.network.get(address)
        return markups[name].kind if name in markups.names else None

    # --- editing --------------------------------------------------------------------------------
    def _edited(self, item: QTableWidgetItem) -> None:
        address, name = item.data(ROW_KEY)
        row = item.row()
        try:
            markups = self.network.get(address)
            old = markups[name]
            new = Markup(name=self.table.item(row, NAME).text(), kind=old.kind,
                         points=parse_points(self.table.item(row, COORDINATES).text()),
                         visible=self.table.item(row, VISIBLE).checkState() == Qt.Checked)
            replaced = Markups(markups=tuple(new if m.name == name else m for m in markups.markups))
            self.workspace.set_property(address, replaced)
        except (VGraphError, ValueError, KeyError) as error:
            self.status_message.emit(f"{address}: {name}: {_reason(error)}")
            self.refresh()
            return
        if new.name != name:
            self.select(address, new.name, emit=False)

    def profile_selected(self) -> None:
        key = self.selected_markup()
        if key is None or self._kind(*key) != "ruler":
            self.status_message.emit("select a ruler's row to profile it")
            return
        try:
            profile_id, problem = profile_ruler(self.workspace, *key)
        except VGraphError as error:
            self.status_message.emit(f"cannot profile {key[1]}: {error}")
            return
        self.status_message.emit(problem or f"{profile_id}: the profile along {key[1]}, following it")
        self.profiled.emit(profile_id)

    def delete_selected(self) -> None:
        chosen = [self._key(index.row()) for index in self.table.selectionModel().selectedRows()]
        for address in dict.fromkeys(address for address, _ in chosen):
            names = {name for a, name in chosen if a == address}
            markups = self.network.get(address)
            self.workspace.set_property(address, Markups(markups=tuple(m for m in markups.markups
                                                                       if m.name not in names)))


def _reason(error: Exception) -> str:
    """A pydantic error's first message, else the error's text."""
    errors = getattr(error, "errors", None)
    if callable(errors):
        first = errors()[0]
        return str(first.get("msg", error))
    return str(error)


def markups_dock(window) -> QDockWidget:
    """The dock, tabbed with the Log and hidden; a row's selection selects its processor in the
    network editor and the markup's row in the inspector's markups table."""
    table = MarkupsTable(window.workspace)
    dock = log_tab(window, "Markups", table)
    table.markup_selected.connect(lambda key: _select_in_window(window, key))
    table.profiled.connect(window.scene.select_processor)
    return dock


def _select_in_window(window, key) -> None:
    if key is None:
        return
    address, name = key
    processor_id, prop = address.split(".", 1)
    if processor_id in window.scene.nodes:
        window.scene.select_processor(processor_id)   # the inspector follows the selection
    editor = window.inspector.editors.get(prop)
    if window.inspector.processor_id == processor_id and hasattr(editor, "table"):
        names = [m.name for m in window.workspace.network.get(address).markups]
        if name in names:
            editor.table.selectRow(names.index(name))


def free_id(network, stem: str) -> str:
    return next(f"{stem}{n}" if n else stem for n in range(len(network.processors) + 2)
                if (f"{stem}{n}" if n else stem) not in network.processors)


def profile_ruler(workspace, address: str, name: str) -> tuple[str, str | None]:
    """Add a LineProfile along ruler ``name`` of ``address`` (linked, so it follows the ruler) and a
    Canvas for its plot, as one undo step: (the profile's id, a problem to report or None)."""
    network = workspace.network
    markups_id = address.split(".")[0]
    x, y = network[markups_id].position
    profile_id, canvas_id = free_id(network, "profile"), free_id(network, "profile_canvas")
    volumes = network.inputs_of(markups_id, "volume")
    with workspace.macro(f"Profile {name}"):
        workspace.add_processor("LineProfile", (x + 180.0, y), id=profile_id)
        workspace.link(address, f"{profile_id}.markups")
        workspace.set_property(f"{profile_id}.ruler", name)
        workspace.add_processor("Canvas", (x + 180.0, y + 120.0), id=canvas_id)
        workspace.connect(f"{profile_id}.plot", f"{canvas_id}.image")
        if volumes:
            workspace.connect(f"{volumes[0].source}.{volumes[0].outport}", f"{profile_id}.volume")
    problem = None if volumes else (f"{profile_id}: connect the volume to sample to {profile_id}.volume "
                                    f"(nothing feeds {markups_id}.volume to take it from)")
    return profile_id, problem
