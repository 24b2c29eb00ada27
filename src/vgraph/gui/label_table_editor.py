"""The label-table editor: one row per listed label (value, name, colour, opacity, visible) and how
unlisted labels are drawn (vgraph.labels.LabelTable), for the LabelRayCaster's ``label_table``.

Conventions (as every editor, see editors.py):
- Every change emits the whole table as its JSON form (a dict) with ``merge=None``: one undo step
  per edit. The editor does not validate: a table the workspace refuses (say, two rows with one
  value) is reported by the inspector, which then shows the current table again.
- A colour is chosen with QColorDialog; opacity with a spin box (two decimals shown, the value kept
  exactly when untouched); visibility with a check box; value and name by typing in the cell.
- Add puts the smallest unused label value >= 1 (its palette colour, opaque); Remove drops the
  selected rows: those labels become unlisted again (palette colour or hidden).
- Emitted numbers are rounded to 6 decimals (QColor keeps float32 channels) to keep files readable.
"""

from __future__ import annotations

from PySide6.QtGui import QColor
from PySide6.QtWidgets import (QCheckBox, QColorDialog, QComboBox, QDoubleSpinBox, QHBoxLayout, QLabel,
                               QPushButton, QSizePolicy, QTableWidgetItem, QVBoxLayout)

from vgraph.gui.editors import PropertyEditor, list_popup, register_editor, row_table, spin_value
from vgraph.labels import LabelTable, palette_color

COLUMNS = ("label", "name", "colour", "opacity", "visible")
VALUE, NAME, COLOUR, OPACITY, VISIBLE = range(len(COLUMNS))
DECIMALS = 6
VISIBLE_ROWS = 8  # rows shown before the table scrolls


def _hex(rgb) -> str:
    return "#" + "".join(f"{round(c * 255):02x}" for c in rgb)


class LabelTableEditor(PropertyEditor):
    """A table of the listed labels, Add/Remove, and the rule for unlisted labels."""

    def build(self):
        column = QVBoxLayout()
        self.table = row_table(COLUMNS, NAME)
        self.table.itemChanged.connect(self._item_changed)
        column.addWidget(self.table)
        buttons = QHBoxLayout()
        self.add = QPushButton("Add")
        self.add.setToolTip("list the smallest unused label value (its palette colour)")
        self.add.clicked.connect(self.add_label)
        self.remove = QPushButton("Remove")
        self.remove.setToolTip("unlist the selected labels (they follow the unlisted rule again)")
        self.remove.clicked.connect(self.remove_selected)
        buttons.addWidget(self.add)
        buttons.addWidget(self.remove)
        buttons.addStretch(1)
        buttons.addWidget(QLabel("unlisted"))
        self.unlisted = list_popup(QComboBox())
        self.unlisted.addItems(["palette", "hidden"])
        self.unlisted.setToolTip("labels the table does not list: palette colours or not drawn")
        self.unlisted.currentTextChanged.connect(lambda text: self._emit_with(unlisted=text))
        buttons.addWidget(self.unlisted)
        self.unlisted_opacity = self._opacity_spin()
        self.unlisted_opacity.setToolTip("opacity of unlisted labels drawn with palette colours")
        self.unlisted_opacity.valueChanged.connect(lambda _: self._emit_with(
            unlisted_opacity=spin_value(self.unlisted_opacity, self.current.unlisted_opacity)))
        buttons.addWidget(self.unlisted_opacity)
        column.addLayout(buttons)
        self.layout_.addLayout(column)
        self.setSizePolicy(QSizePolicy.Preferred, QSizePolicy.Maximum)  # no gap below the table

    @property
    def current(self) -> LabelTable:
        return self.processor.property_values[self.prop.name]

    @staticmethod
    def _opacity_spin() -> QDoubleSpinBox:
        spin = QDoubleSpinBox()
        spin.setRange(0.0, 1.0)
        spin.setDecimals(2)
        spin.setSingleStep(0.05)
        spin.setKeyboardTracking(False)
        return spin

    # --- showing --------------------------------------------------------------------------------
    def _show(self, value: LabelTable):
        self.table.blockSignals(True)
        try:
            self.table.setRowCount(len(value.labels))
            for row, entry in enumerate(value.labels):
                self._show_row(row, entry)
        finally:
            self.table.blockSignals(False)
        self._fit_rows(len(value.labels))
        self.unlisted.setCurrentText(value.unlisted)
        self.unlisted_opacity.setValue(value.unlisted_opacity)
        self.unlisted_opacity.setEnabled(value.unlisted == "palette")

    def _fit_rows(self, count: int) -> None:
        """As tall as its rows (at least 2, at most VISIBLE_ROWS; more scroll): no empty area."""
        self.table.resizeRowsToContents()
        row = self.table.rowHeight(0) if count else self.table.verticalHeader().defaultSectionSize()
        shown = min(max(count, 2), VISIBLE_ROWS)
        self.table.setFixedHeight(self.table.horizontalHeader().height() + shown * row
                                  + 2 * self.table.frameWidth() + 2)

    def _show_row(self, row: int, entry) -> None:
        self.table.setItem(row, VALUE, QTableWidgetItem(str(entry.value)))
        self.table.setItem(row, NAME, QTableWidgetItem(entry.name))
        button = QPushButton(_hex(entry.color))
        ink = "#000000" if QColor.fromRgbF(*entry.color).lightnessF() > 0.5 else "#ffffff"
        button.setStyleSheet(f"background-color: {_hex(entry.color)}; color: {ink};")
        button.clicked.connect(lambda _=False, r=row: self.choose_color(r))
        self.table.setCellWidget(row, COLOUR, button)
        spin = self._opacity_spin()
        spin.setValue(entry.opacity)
        spin.valueChanged.connect(lambda _, r=row: self._row_changed(r))
        self.table.setCellWidget(row, OPACITY, spin)
        visible = QCheckBox()
        visible.setChecked(entry.visible)
        visible.toggled.connect(lambda _, r=row: self._row_changed(r))
        self.table.setCellWidget(row, VISIBLE, visible)

    # --- editing --------------------------------------------------------------------------------
    def rows(self) -> list[dict]:
        """The listed labels as the table shows them (JSON form); cells keep the exact values of the
        current table where the widgets show them rounded."""
        current = self.current.labels
        rows = []
        for row in range(self.table.rowCount()):
            exact = current[row] if row < len(current) else None
            text = self.table.item(row, VALUE).text().strip()
            try:
                value = int(text)
            except ValueError:
                value = text  # the workspace refuses it and says why
            rows.append({"value": value, "name": self.table.item(row, NAME).text(),
                         "color": list(exact.color) if exact else [1.0, 1.0, 1.0],
                         "opacity": spin_value(self.table.cellWidget(row, OPACITY),
                                               exact.opacity if exact else None),
                         "visible": self.table.cellWidget(row, VISIBLE).isChecked()})
        return rows

    def _document(self, rows=None, **changes) -> dict:
        return {"labels": self.rows() if rows is None else rows, "unlisted": self.current.unlisted,
                "unlisted_opacity": self.current.unlisted_opacity, **changes}

    def _emit_with(self, **changes) -> None:
        self.emit(self._document(**changes))

    def _item_changed(self, item) -> None:
        self._row_changed(item.row())

    def _row_changed(self, row: int) -> None:
        self._emit_with()

    def set_color(self, row: int, rgb) -> None:
        rows = self.rows()
        rows[row]["color"] = [round(float(c), DECIMALS) for c in rgb]
        self.emit(self._document(rows))

    def choose_color(self, row: int) -> None:
        entry = self.current.labels[row]
        color = QColorDialog.getColor(QColor.fromRgbF(*entry.color), self,
                                      f"{self.prop.label}: label {entry.value}")
        if color.isValid():
            self.set_color(row, (color.redF(), color.greenF(), color.blueF()))

    def add_label(self) -> None:
        taken = {entry.value for entry in self.current.labels}
        value = next(v for v in range(1, len(taken) + 2) if v not in taken)
        rows = self.rows() + [{"value": value, "name": "", "color": list(palette_color(value)),
                               "opacity": 1.0, "visible": True}]
        self.emit(self._document(sorted(rows, key=lambda r: r["value"] if isinstance(r["value"], int) else 0)))

    def remove_selected(self) -> None:
        selected = {index.row() for index in self.table.selectionModel().selectedRows()}
        if selected:
            self.emit(self._document([r for i, r in enumerate(self.rows()) if i not in selected]))


register_editor("label_table", LabelTableEditor)
