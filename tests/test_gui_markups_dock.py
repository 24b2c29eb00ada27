"""The Markups dock (issue 36, vgraph.gui.markups_dock): every markup of the network in one table,
following every change; a row's selection selects the markup (its processor in the editor and the
inspector's row); edits and deletes are undoable, refused edits change nothing and say why."""

import pytest

from vgraph.markups import Markup, Markups

RULER = Markup(name="r", kind="ruler", points=((0.0, 0.0, 0.0), (3.0, 4.0, 0.0)))
ANGLE = Markup(name="a", kind="angle", points=((1.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 2.0, 0.0)))
POINTS = Markup(name="p", kind="points", points=((5.0, 5.0, 5.0),))


@pytest.fixture
def marked(window):
    workspace = window.workspace
    workspace.add_processor("Markups", (0, 0), id="mk")
    workspace.add_processor("Markups", (200, 0), id="more")
    workspace.set_property("mk.units", "mm")
    workspace.set_property("mk.markups", Markups(markups=(RULER, ANGLE)))
    workspace.set_property("more.markups", Markups(markups=(POINTS,)))
    return window


def cells(table, row):
    return [table.item(row, col).text() for col in range(table.columnCount() - 1)]


def test_the_dock_lists_every_markup_of_the_network_and_follows_changes(marked):
    dock = marked.markups_dock
    assert dock.windowTitle() == "Markups" and not dock.isVisible()   # View > Markups shows it
    table = dock.widget().table
    assert [cells(table, row) for row in range(table.rowCount())] == [
        ["mk", "r", "ruler", "2", "5 mm", "0.0 0.0 0.0; 3.0 4.0 0.0"],
        ["mk", "a", "angle", "3", "90.00°", "1.0 0.0 0.0; 0.0 0.0 0.0; 0.0 2.0 0.0"],
        ["more", "p", "points", "1", "", "5.0 5.0 5.0"]]
    marked.workspace.undo_stack.undo()   # the point list goes: the table follows
    assert table.rowCount() == 2


def test_selecting_a_row_selects_the_markup_in_the_editor_and_the_inspector(marked):
    table = marked.markups_dock.widget().table
    table.selectRow(1)
    assert marked.markups_dock.widget().selected_markup() == ("mk.markups", "a")
    assert marked.inspector.processor_id == "mk"
    inspector_table = marked.inspector.editors["markups"].table
    assert [i.row() for i in inspector_table.selectionModel().selectedRows()] == [1]
    table.selectRow(2)
    assert marked.inspector.processor_id == "more"


def test_edits_in_the_dock_are_undoable(marked):
    dock, network, undo = marked.markups_dock.widget(), marked.workspace.network, marked.workspace.undo_stack
    table = dock.table
    steps = undo.count()
    table.item(0, 5).setText("0 0 0; 6 8 0")   # the ruler's coordinates
    assert network.get("mk.markups")["r"].length == pytest.approx(10.0)
    assert table.item(0, 4).text() == "10 mm"
    table.item(0, 1).setText("width")            # its name
    assert network.get("mk.markups").names == ["width", "a"]
    assert undo.count() == steps + 2
    undo.undo()
    undo.undo()
    assert network.get("mk.markups")["r"].length == pytest.approx(5.0)
    assert table.item(0, 1).text() == "r"


def test_a_refused_edit_changes_nothing_and_says_why(marked):
    dock, network, undo = marked.markups_dock.widget(), marked.workspace.network, marked.workspace.undo_stack
    steps = undo.count()
    dock.table.item(0, 5).setText("0 0 0; 1 1 1; 2 2 2")   # a ruler with three points
    assert network.get("mk.markups")["r"] == RULER and undo.count() == steps
    assert "exactly 2 points" in marked.statusBar().currentMessage()
    assert dock.table.item(0, 5).text() == "0.0 0.0 0.0; 3.0 4.0 0.0"
    dock.table.item(1, 1).setText("r")                       # a name taken
    assert network.get("mk.markups").names == ["r", "a"] and undo.count() == steps
    assert "named 'r'" in marked.statusBar().currentMessage()


def test_delete_removes_the_selected_markups_undoably(marked):
    dock, network, undo = marked.markups_dock.widget(), marked.workspace.network, marked.workspace.undo_stack
    dock.table.selectRow(0)
    dock.delete_selected()
    assert network.get("mk.markups").names == ["a"] and dock.table.rowCount() == 2
    undo.undo()
    assert network.get("mk.markups").names == ["r", "a"]


def test_profile_adds_a_line_profile_that_follows_the_ruler_in_one_undo_step(window, qtbot):
    """Profile on a ruler's row: a LineProfile linked to the ruler (not a copy of its points), its
    volume from what feeds the Markups node, a Canvas for the plot; one undo step removes all."""
    from helpers.paths import DATA
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    workspace = window.workspace
    workspace.add_processor("VolumeSource", (0, 0), id="source")
    workspace.set_property("source.path", str(DATA / "ct_head_headsq" / "quarter.nhdr"))
    workspace.add_processor("Markups", (0, 120), id="mk")
    workspace.connect("source.volume", "mk.volume")
    workspace.set_property("mk.markups", Markups(markups=(RULER, ANGLE)))
    dock = window.markups_dock.widget()
    dock.table.selectRow(1)
    assert not dock.profile.isEnabled()      # an angle has no profile
    dock.table.selectRow(0)
    assert dock.profile.isEnabled()
    steps, network = workspace.undo_stack.count(), workspace.network
    dock.profile.click()
    assert workspace.undo_stack.count() == steps + 1
    assert network.get("profile.ruler") == "r" and network.inputs_of("profile", "volume")[0].source == "source"
    assert any((link.source, link.target) == ("mk.markups", "profile.markups") for link in network.links)
    assert network.inputs_of("profile_canvas", "image")[0].source == "profile"
    assert window.inspector.processor_id == "profile"
    assert dock.table.rowCount() == 2        # the profile's linked markups are the same: listed once
    dock.table.item(0, 5).setText("0 0 0; 30 40 0")   # the ruler moves: the profile's line follows
    assert network["profile"].length == pytest.approx(50.0)
    workspace.undo_stack.undo()
    workspace.undo_stack.undo()
    assert "profile" not in network.processors and "profile_canvas" not in network.processors
