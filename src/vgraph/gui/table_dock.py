"""The Tables dock: the whole table a measuring processor output (RegionStatistics, LineProfile,
Markups: every processor with a Table outport), sortable, copied and saved (issue 36;
docs/guide/measuring.md, "The Tables dock"). The inspector shows 12 rows as text; this shows all.

Conventions:
- It shows the table of the processor selected in the network editor; selecting one without a
  table (a Canvas) keeps the last table shown, so a profile's table stays beside its plot. It
  follows every evaluation: the render process sends the tables (vgraph.live.tables), the
  window's LiveEvaluation holds them, ``tables_changed`` says when.
- Numbers are shown to 6 significant digits (vgraph.table.cell_text); a click on a heading sorts by
  that column (numpy's stable argsort; NaN last both ways), the model reorders an index, the
  table stays as it came; the row headers keep each row's number in the table.
- Ctrl+C (or Copy) puts the selected cells' rows and columns, in the order shown, on the clipboard
  as tab-separated text with a heading row, every digit kept (the CSV's numbers): a spreadsheet
  takes it as it is. Save CSV... writes the whole table in its own order, byte for byte what
  ``vgraph run --port ID.table --data OUT.csv`` writes (Table.to_csv, atomic).
- Created hidden, tabbed with the Log (View > Tables shows it).
"""

from __future__ import annotations

import numpy as np
import shiboken6
from PySide6.QtCore import QAbstractTableModel, QModelIndex, Qt, Signal
from PySide6.QtGui import QGuiApplication, QKeySequence
from PySide6.QtWidgets import (QAbstractItemView, QDockWidget, QFileDialog, QHBoxLayout, QLabel, QPushButton,
                               QTableView, QVBoxLayout, QWidget)

from vgraph.errors import VGraphError
from vgraph.gui.layout import log_tab
from vgraph.table import Table, cell_text

NOTHING = "select a processor with a table (RegionStatistics, LineProfile, Markups) in the network editor"


class TableModel(QAbstractTableModel):
    """A Table's cells, in ``order`` (the sorted row indices)."""

    def __init__(self, parent=None):
        super().__init__(parent)
        self.table: Table | None = None
        self.order = np.zeros(0, dtype=np.intp)
        self.sorted_by: tuple[int, Qt.SortOrder] | None = None

    def show(self, table: Table | None) -> None:
        self.beginResetModel()
        self.table = table
        self.order = np.arange(table.row_count if table is not None else 0)
        if self.sorted_by is not None and table is not None and self.sorted_by[0] < len(table.columns):
            self.order = sorted_order(table.columns[self.sorted_by[0]].values, self.sorted_by[1])
        self.endResetModel()

    def rowCount(self, parent=QModelIndex()) -> int:
        return 0 if parent.isValid() else len(self.order)

    def columnCount(self, parent=QModelIndex()) -> int:
        return 0 if parent.isValid() or self.table is None else len(self.table.columns)

    def data(self, index, role=Qt.DisplayRole):
        if not index.isValid() or self.table is None:
            return None
        values = self.table.columns[index.column()].values
        if role == Qt.DisplayRole:
            return cell_text(values[self.order[index.row()]].item())
        if role == Qt.TextAlignmentRole and values.dtype.kind != "U":
            return int(Qt.AlignRight | Qt.AlignVCenter)
        return None

    def headerData(self, section, orientation, role=Qt.DisplayRole):
        if role != Qt.DisplayRole:
            return None
        if orientation == Qt.Horizontal:
            return self.table.columns[section].heading if self.table is not None else None
        return str(self.order[section] + 1)   # the row's place in the table, sorted or not

    def sort(self, column: int, order=Qt.AscendingOrder) -> None:
        if self.table is None or not 0 <= column < len(self.table.columns):
            return
        self.layoutAboutToBeChanged.emit()
        self.sorted_by = (column, order)
        self.order = sorted_order(self.table.columns[column].values, order)
        self.layoutChanged.emit()


def sorted_order(values: np.ndarray, order) -> np.ndarray:
    """Row indices sorting ``values`` (stable; NaN last whether ascending or descending)."""
    if order == Qt.AscendingOrder:
        return np.argsort(values, kind="stable")
    if values.dtype.kind == "f":
        return np.argsort(-values, kind="stable")   # -NaN is NaN: still last
    _, ranks = np.unique(values, return_inverse=True)  # whole numbers of any width, names
    return np.argsort(-ranks.reshape(-1), kind="stable")


class CopyingView(QTableView):
    """Ctrl+C copies the selection (``copy`` of the dock)."""

    copy_requested = Signal()

    def keyPressEvent(self, event) -> None:
        if event.matches(QKeySequence.Copy):
            self.copy_requested.emit()
            return
        super().keyPressEvent(event)


class TablePanel(QWidget):
    """What the dock shows: the address and row count, the table, Copy and Save CSV..."""

    status_message = Signal(str)

    def __init__(self, evaluation, parent=None):
        super().__init__(parent)
        self.evaluation = evaluation
        self.address: str | None = None   # 'id.port' of the table shown
        self.title = QLabel(NOTHING)
        self.title.setWordWrap(True)
        self.model = TableModel(self)
        self.view = CopyingView()
        self.view.setModel(self.model)
        self.view.setSortingEnabled(True)
        self.view.horizontalHeader().setSortIndicatorShown(True)
        self.view.setSelectionMode(QAbstractItemView.ExtendedSelection)
        self.view.setEditTriggers(QAbstractItemView.NoEditTriggers)
        self.view.verticalHeader().setDefaultSectionSize(self.view.fontMetrics().height() + 6)
        self.view.copy_requested.connect(self.copy)
        copy = QPushButton("Copy")
        copy.setToolTip("the selected cells as tab-separated text, with headings (Ctrl+C)")
        copy.clicked.connect(self.copy)
        self.save = QPushButton("Save CSV...")
        self.save.setToolTip("the whole table as CSV, as vgraph run --data writes it")
        self.save.clicked.connect(self.save_dialog)
        buttons = QHBoxLayout()
        buttons.addWidget(copy)
        buttons.addWidget(self.save)
        buttons.addStretch(1)
        column = QVBoxLayout(self)
        column.addWidget(self.title)
        column.addWidget(self.view)
        column.addLayout(buttons)
        evaluation.tables_changed.connect(self.refresh)
        self.refresh()

    def show_processor(self, processor_id: str | None) -> None:
        """Show ``processor_id``'s table if it has a table outport; otherwise keep what is shown."""
        network = self.evaluation.workspace.network
        if processor_id is None or processor_id not in network.processors:
            return
        ports = [port.name for port in network[processor_id].outports if issubclass(port.data_type, Table)]
        if ports:
            self.address = f"{processor_id}.{ports[0]}"
            self.refresh()

    def forget(self, *_) -> None:
        """Another network: nothing to show until a processor is selected."""
        self.address = None
        self.refresh()

    @property
    def table(self) -> Table | None:
        return self.evaluation.tables.get(self.address) if self.address else None

    def refresh(self) -> None:
        table = self.table
        if self.model.table is not table:
            self.model.show(table)
            self.view.resizeColumnsToContents()
        if self.address is None:
            self.title.setText(NOTHING)
        elif table is None:
            self.title.setText(f"{self.address}: no table yet (the processor has not run, or failed: "
                               "see its status in the inspector)")
        else:
            self.title.setText(f"{self.address}: {table.row_count} row{'s' * (table.row_count != 1)}")
        self.save.setEnabled(table is not None)

    # --- copy and save --------------------------------------------------------------------------
    def selection_text(self) -> str:
        """The selected cells' rows and columns, in the order shown, as tab-separated text."""
        indexes = self.view.selectionModel().selectedIndexes()
        if self.model.table is None or not indexes:
            return ""
        rows = sorted({index.row() for index in indexes})
        columns = sorted({index.column() for index in indexes})
        table = self.model.table
        return table.take(self.model.order[rows], [table.columns[c].name for c in columns]).csv_text("\t")

    def copy(self) -> None:
        text = self.selection_text()
        if text:
            QGuiApplication.clipboard().setText(text)
            self.status_message.emit(f"copied {text.count(chr(10)) - 1} rows of {self.address}")

    def save_dialog(self) -> None:
        if self.table is None:
            return
        path, _ = QFileDialog.getSaveFileName(self, "Save the table as CSV", f"{self.address.split('.')[0]}.csv",
                                              "CSV files (*.csv)")
        if path:
            self.save_csv(path)

    def save_csv(self, path) -> bool:
        table = self.table
        if table is None:
            return False
        try:
            table.to_csv(path)
        except VGraphError as error:   # atomic writes say what is wrong with the path
            self.status_message.emit(str(error))
            return False
        except OSError as error:
            self.status_message.emit(f"cannot write {path}: {error.strerror or error}")
            return False
        self.status_message.emit(f"wrote {table.row_count} rows of {self.address} to {path}")
        return True


def table_dock(window) -> QDockWidget:
    """The dock, tabbed with the Log and hidden; it shows the table of the processor selected in
    the network editor."""
    panel = TablePanel(window.evaluation)
    dock = log_tab(window, "Tables", panel)
    window.scene.selectionChanged.connect(lambda: _selected(window, panel))
    window.workspace.network_replaced.connect(panel.forget)
    return dock


def _selected(window, panel: TablePanel) -> None:
    if not (shiboken6.isValid(window.scene) and shiboken6.isValid(panel)):
        return   # the window is being torn down: the scene clears its selection as it goes
    processors, _, _ = window.scene.selection()
    if len(processors) == 1:
        panel.show_processor(processors[0])
