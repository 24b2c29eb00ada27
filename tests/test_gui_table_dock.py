"""The Tables dock (issue 36, vgraph.gui.table_dock): the selected processor's whole table as the
render process sent it, sortable, copied as tab-separated text and saved as the CLI's CSV."""

import subprocess
import sys

import numpy as np
import pytest
from PySide6.QtCore import Qt
from PySide6.QtGui import QGuiApplication

from vgraph.io.writers import write_volume
from vgraph.volume import Volume


@pytest.fixture
def stats_window(window, tmp_path):
    """RegionStatistics of 14 labels, label k on 15 - k voxels, saved for the command line."""
    labels = np.zeros((4, 6, 20), np.uint8)
    for k in range(1, 15):
        labels[k % 4, k // 4, : 15 - k] = k   # label k covers 15 - k voxels: counts fall as labels rise
    path = write_volume(Volume(labels, spacing=(0.5, 1.0, 2.0)), tmp_path / "labels.nrrd")
    workspace = window.workspace
    workspace.add_processor("VolumeSource", (0, 0), id="source")
    workspace.set_property("source.path", str(path))
    workspace.add_processor("RegionStatistics", (0, 120), id="stats")
    workspace.set_property("stats.surface_area", False)
    workspace.connect("source.volume", "stats.labels")
    window.evaluation.run(wait=True)
    window.stats_network = tmp_path / "stats.json"
    workspace.save_as(window.stats_network)
    return window


def shown(panel):
    model = panel.model
    return [[model.index(row, col).data() for col in range(model.columnCount())] for row in range(model.rowCount())]


def test_the_dock_shows_every_row_of_the_selected_processors_table_and_sorts(stats_window):
    dock = stats_window.table_dock
    assert dock.windowTitle() == "Tables" and not dock.isVisible()   # View > Tables shows it
    panel = dock.widget()
    stats_window.scene.select_processor("source")    # no table: nothing to show yet
    assert panel.address is None and panel.model.rowCount() == 0
    stats_window.scene.select_processor("stats")
    assert panel.address == "stats.table" and panel.title.text() == "stats.table: 14 rows"
    assert [panel.model.headerData(c, Qt.Horizontal) for c in range(3)] == ["label", "count", "volume [world^3]"]
    rows = shown(panel)
    assert [row[0] for row in rows] == [str(k) for k in range(1, 15)]   # all 14, more than the inspector's 12
    assert [row[1] for row in rows] == [str(15 - k) for k in range(1, 15)]
    panel.view.sortByColumn(1, Qt.AscendingOrder)    # by count: label 14 (1 voxel) first
    assert [row[0] for row in shown(panel)] == [str(k) for k in range(14, 0, -1)]
    assert panel.model.headerData(0, Qt.Vertical) == "14"   # row headers: the row's place in the table
    panel.view.sortByColumn(0, Qt.DescendingOrder)
    assert [row[0] for row in shown(panel)] == [str(k) for k in range(14, 0, -1)]
    stats_window.scene.select_processor("source")    # a processor without a table keeps the table shown
    assert panel.address == "stats.table"


def test_the_dock_follows_a_new_evaluation(stats_window):
    panel = stats_window.table_dock.widget()
    stats_window.scene.select_processor("stats")
    stats_window.workspace.set_property("stats.regions", "mask")
    stats_window.evaluation.run(wait=True)
    assert [row[:2] for row in shown(panel)] == [["1", str(sum(range(1, 15)))]]


def test_copy_gives_the_selected_cells_as_tab_separated_text(stats_window, qtbot):
    panel = stats_window.table_dock.widget()
    stats_window.scene.select_processor("stats")
    panel.view.sortByColumn(1, Qt.AscendingOrder)
    model, selection = panel.model, panel.view.selectionModel()
    for row in (0, 2):
        for col in (0, 2):
            selection.select(model.index(row, col), selection.SelectionFlag.Select)
    qtbot.keyClick(panel.view, Qt.Key_C, Qt.ControlModifier)
    assert QGuiApplication.clipboard().text() == "label\tvolume [world^3]\n14\t1.0\n12\t3.0\n"


def test_save_csv_writes_what_the_command_line_writes(stats_window, tmp_path):
    panel = stats_window.table_dock.widget()
    stats_window.scene.select_processor("stats")
    panel.view.sortByColumn(1, Qt.AscendingOrder)    # the file keeps the table's own order
    assert panel.save_csv(tmp_path / "dock.csv")
    subprocess.run([sys.executable, "-m", "vgraph", "run", str(stats_window.stats_network), "--port", "stats.table",
                    "--data", str(tmp_path / "cli.csv")], check=True, capture_output=True)
    assert (tmp_path / "dock.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    assert (tmp_path / "dock.csv").read_text().splitlines()[1] == "1,14,14.0"   # label, count, volume
    assert not panel.save_csv(tmp_path / "missing" / "dock.csv")   # a folder that is not there: said, not raised
    assert "cannot write" in stats_window.statusBar().currentMessage()


def test_sorting_keeps_nan_last_and_sorts_names_and_whole_numbers_both_ways():
    from vgraph.gui.table_dock import sorted_order
    values = np.array([2.0, np.nan, -1.0, 5.0, np.nan, 2.0])
    assert sorted_order(values, Qt.AscendingOrder).tolist() == [2, 0, 5, 3, 1, 4]
    assert sorted_order(values, Qt.DescendingOrder).tolist() == [3, 0, 5, 2, 1, 4]
    names = np.array(["casing", "", "dense parts", "casing"])
    assert sorted_order(names, Qt.DescendingOrder).tolist() == [2, 0, 3, 1]
    big = np.array([2**63 - 1, 0, 2**62], dtype=np.uint64)
    assert sorted_order(big, Qt.DescendingOrder).tolist() == [0, 2, 1]
