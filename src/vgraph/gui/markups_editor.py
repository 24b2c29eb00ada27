"""The markups editor: the Markups processor's ``markups`` as a table in the inspector (name, kind,
length or angle, points, visible), with Add, Remove, Import and Export (vgraph.markups_files).

Conventions (as every editor, see editors.py):
- Every change emits the whole markups as their JSON form (a list of markups) with ``merge=None``:
  one undo step per edit. The editor does not validate: markups the workspace refuses (a ruler
  with three points, two markups of one name) are reported by the inspector, which then shows the
  current markups again.
- Points are typed as text, "x y z" per point, points separated by ";" (commas between numbers are
  taken too); the measurement column is the model's (read only).
- Add puts a markup of the processor's ``place_kind`` with a free name ("ruler 1", ...) at points around the
  world origin, to be typed or imported over; Remove drops the selected rows.
- Import replaces the markups with a file's (CSV, JSON, Slicer .mrk.json); Export writes them.
  A file's problem (MarkupsFileError, OutputFileError) is reported, nothing changes.
"""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (QFileDialog, QHBoxLayout, QPushButton, QSizePolicy, QTableWidgetItem,
                               QVBoxLayout)

from vgraph.errors import VGraphError
from vgraph.gui.editors import PropertyEditor, register_editor, row_table
from vgraph.markups import Markup, Markups, free_name
from vgraph.markups_files import read_markups, write_markups

COLUMNS = ("name", "kind", "measured", "points", "visible")
NAME, KIND, MEASURED, POINTS, VISIBLE = range(len(COLUMNS))
NEW_POINTS = {"points": [[0.0, 0.0, 0.0]], "ruler": [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]],
              "angle": [[10.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 10.0, 0.0]],
              "closed_curve": [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [10.0, 10.0, 0.0], [0.0, 10.0, 0.0]]}
FILES = "Markups (*.csv *.json *.mrk.json)"


def chosen_kind(processor) -> str:
    """The kind Add and the mouse start next: the Markups processor's ``place_kind`` (a property
    of its own, so it is saved, undone and shown in the inspector like any other)."""
    return processor.place_kind


def measured_text(markup: Markup) -> str:
    if markup.angle is not None:
        return f"{markup.angle:.2f}°"
    if markup.length is not None:
        return f"{markup.length:.6g}"
    return ""


def points_text(markup: Markup) -> str:
    """'x y z; x y z', each number as Python's repr (the shortest text that reads back exactly)."""
    return "; ".join(" ".join(repr(v) for v in point) for point in markup.points)


def parse_points(text: str):
    """'x y z; x y z' as a list of lists of numbers; a cell that does not parse is handed on as
    text, for the workspace to refuse with its reason."""
    try:
        return [[float(v) for v in point.replace(",", " ").split()] for point in text.split(";") if point.strip()]
    except ValueError:
        return text


class MarkupsEditor(PropertyEditor):
    """A table of the markups, Add/Remove and Import/Export."""

    def build(self):
        column = QVBoxLayout()
        self.table = row_table(COLUMNS, POINTS)
        self.table.itemChanged.connect(lambda _item: self.emit(self.rows()))
        column.addWidget(self.table)
        buttons = QHBoxLayout()
        for label, tip, action in (("Add", "add a markup of the kind 'place kind' names", self.add_markup),
                                   ("Remove", "remove the selected markups", self.remove_selected),
                                   ("Import...", "replace the markups with a file's (CSV, JSON, Slicer)",
                                    self.import_file),
                                   ("Export...", "write the markups to CSV, JSON or Slicer's .mrk.json",
                                    self.export_file)):
            button = QPushButton(label)
            button.setToolTip(tip)
            button.clicked.connect(action)
            buttons.addWidget(button)
        buttons.addStretch(1)
        column.addLayout(buttons)
        self.layout_.addLayout(column)
        self.setSizePolicy(QSizePolicy.Preferred, QSizePolicy.Maximum)

    @property
    def current(self) -> Markups:
        return self.processor.property_values[self.prop.name]

    # --- showing --------------------------------------------------------------------------------
    def _show(self, value: Markups):
        self.table.blockSignals(True)
        try:
            self.table.setRowCount(len(value.markups))
            for row, markup in enumerate(value.markups):
                self._show_row(row, markup)
        finally:
            self.table.blockSignals(False)

    def _show_row(self, row: int, markup: Markup) -> None:
        self.table.setItem(row, NAME, QTableWidgetItem(markup.name))
        for col, text in ((KIND, markup.kind), (MEASURED, measured_text(markup))):
            item = QTableWidgetItem(text)
            item.setFlags(item.flags() & ~Qt.ItemIsEditable)
            self.table.setItem(row, col, item)
        self.table.setItem(row, POINTS, QTableWidgetItem(points_text(markup)))
        visible = QTableWidgetItem()
        visible.setFlags((visible.flags() | Qt.ItemIsUserCheckable) & ~Qt.ItemIsEditable)
        visible.setCheckState(Qt.Checked if markup.visible else Qt.Unchecked)
        self.table.setItem(row, VISIBLE, visible)

    # --- editing --------------------------------------------------------------------------------
    def rows(self) -> list[dict]:
        """The markups as the table shows them (JSON form)."""
        return [{"name": self.table.item(row, NAME).text(), "kind": self.table.item(row, KIND).text(),
                 "points": parse_points(self.table.item(row, POINTS).text()),
                 "visible": self.table.item(row, VISIBLE).checkState() == Qt.Checked}
                for row in range(self.table.rowCount())]

    def add_markup(self) -> None:
        kind = chosen_kind(self.processor)
        name = free_name(self.current, kind)
        self.emit(self.rows() + [{"name": name, "kind": kind, "points": NEW_POINTS[kind], "visible": True}])

    def remove_selected(self) -> None:
        selected = {index.row() for index in self.table.selectionModel().selectedRows()}
        if selected:
            self.emit([r for i, r in enumerate(self.rows()) if i not in selected])

    def import_file(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Import markups", "", FILES)
        if path:
            try:
                markups = read_markups(path)
            except VGraphError as error:
                self.problem.emit(str(error))
                return
            self.emit(markups.model_dump(mode="json")["markups"])

    def export_file(self) -> None:
        path, _ = QFileDialog.getSaveFileName(self, "Export markups", "markups.mrk.json", FILES)
        if path:
            try:
                write_markups(self.current, path)
            except VGraphError as error:
                self.problem.emit(str(error))


register_editor("markups", MarkupsEditor)
