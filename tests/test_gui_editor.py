"""The network editor: add, connect (accepted and refused), disconnect, delete, move and link,
each undone and redone, with the scene following the model."""

from PySide6.QtCore import QPointF, Qt

from vgraph.fileformat import network_document
from vgraph.gui.items import EdgeItem, LinkItem, port_color
from vgraph.gui.links import LinkDialog, link_candidates
from vgraph.network import Connection, Link

from helpers.gui import drag, port_position


def test_palette_search_and_double_click_add_a_processor_undo_redo(window, qtbot):
    palette = window.palette
    palette.search.setText("CUBICSPLINE")  # VolumeResample mentions splines too
    assert palette.visible_types() == ["CubicSplineProcessor"]
    palette.search.setText("volume file")          # words may match description and category
    assert "VolumeSource" in palette.visible_types() and "Grayscale" not in palette.visible_types()
    palette.search.setText("spline")
    category = next(palette.tree.topLevelItem(i) for i in range(palette.tree.topLevelItemCount())
                    if palette.tree.topLevelItem(i).text(0) == "Volume")
    item = next(category.child(j) for j in range(category.childCount())
                if category.child(j).text(0) == "CubicSplineProcessor")
    rect = palette.tree.visualItemRect(item)
    qtbot.mouseClick(palette.tree.viewport(), Qt.LeftButton, pos=rect.center())  # as a user: press first
    qtbot.mouseDClick(palette.tree.viewport(), Qt.LeftButton, pos=rect.center())

    network, stack = window.workspace.network, window.workspace.undo_stack
    assert list(network.processors) == ["cubicSplineProcessor"]
    added = network_document(network)
    assert set(window.scene.nodes) == {"cubicSplineProcessor"}
    assert window.inspector.processor_id == "cubicSplineProcessor"      # the new node is selected
    assert stack.count() == 1 and stack.undoText() == "Add cubicSplineProcessor (CubicSplineProcessor)"

    stack.undo()
    assert list(network.processors) == [] and window.scene.nodes == {}
    assert window.inspector.processor_id is None
    stack.redo()
    # redo adds it again from its record (vgraph.edits): the same type, id, values and place
    assert network_document(network) == added and set(window.scene.nodes) == {"cubicSplineProcessor"}


def test_ports_are_coloured_by_data_type(window):
    window.workspace.add_processor("FunctionSelector", (0, 0))
    window.workspace.add_processor("Grayscale", (250, 0))
    volume_port = window.scene.nodes["functionSelector"].port("out", "volume")
    image_port = window.scene.nodes["grayscale"].port("in", "image")
    assert volume_port.brush().color() == port_color("Volume")
    assert image_port.brush().color() == port_color("Image")
    assert port_color("Volume") != port_color("Image")
    assert port_color("MyPluginType") == port_color("MyPluginType")  # stable for unknown types


def test_drag_from_outport_to_compatible_inport_connects_undo_redo(window, qtbot):
    ws = window.workspace
    ws.add_processor("FunctionSelector", (0, 0))
    ws.add_processor("CubicSplineProcessor", (0, 150))
    drag(qtbot, window, port_position(window, "functionSelector", "out", "volume"),
         port_position(window, "cubicSplineProcessor", "in", "volume"))

    expected = Connection("functionSelector", "volume", "cubicSplineProcessor", "volume")
    assert ws.network.connections == [expected]
    assert isinstance(window.scene.edges[expected], EdgeItem)
    assert window.statusBar().currentMessage() == f"Connected {expected}"
    ws.undo_stack.undo()
    assert ws.network.connections == [] and window.scene.edges == {}
    ws.undo_stack.redo()
    assert ws.network.connections == [expected] and expected in window.scene.edges


def test_drag_to_incompatible_inport_is_refused_with_the_reason(window, qtbot):
    ws = window.workspace
    ws.add_processor("FunctionSelector", (0, 0))
    ws.add_processor("Grayscale", (0, 150))
    ws.add_processor("CubicSplineProcessor", (220, 150))
    count = ws.undo_stack.count()
    start = port_position(window, "functionSelector", "out", "volume")
    refused_at = port_position(window, "grayscale", "in", "image")
    drag(qtbot, window, start, refused_at, release=False)

    # live feedback while dragging: compatible inports highlighted, the others refused
    assert window.scene.nodes["cubicSplineProcessor"].port("in", "volume").verdict == "compatible"
    assert window.scene.nodes["grayscale"].port("in", "image").verdict == "refused"
    reason = ("cannot connect functionSelector.volume -> grayscale.image: functionSelector.volume "
              "carries Volume but grayscale.image takes Image")
    assert window.statusBar().currentMessage() == f"Refused: {reason}"

    qtbot.mouseRelease(window.view.viewport(), Qt.LeftButton, pos=window.view.mapFromScene(refused_at))
    assert ws.network.connections == [] and ws.undo_stack.count() == count
    assert window.statusBar().currentMessage() == f"Refused: {reason}"
    assert window.scene.nodes["grayscale"].port("in", "image").verdict is None  # highlights cleared


def test_select_and_delete_a_connection_undo_redo(window, qtbot):
    ws = window.workspace
    ws.add_processor("FunctionSelector", (0, 0))
    ws.add_processor("CubicSplineProcessor", (0, 150))
    connection = ws.connect("functionSelector.volume", "cubicSplineProcessor.volume")
    window.scene.clearSelection()
    window.scene.edges[connection].setSelected(True)
    window.delete_action.trigger()
    assert ws.network.connections == [] and connection not in window.scene.edges
    ws.undo_stack.undo()
    assert ws.network.connections == [connection] and connection in window.scene.edges
    ws.undo_stack.redo()
    assert ws.network.connections == []


def test_delete_processor_restores_connections_order_and_links_on_undo(window):
    ws = window.workspace
    for name, y in (("a", 0), ("b", 0), ("c", 0)):
        ws.add_processor("Number", ({"a": 0, "b": 200, "c": 400}[name], y), id=name)
    ws.add_processor("Sum", (200, 150), id="total")
    for source in ("a", "b", "c"):
        ws.connect(f"{source}.value", "total.values")
    ws.link("a.value", "b.value")
    ws.link("b.value", "c.value", bidirectional=True)
    before = (list(ws.network.processors), ws.network.connections, list(ws.network.links))

    window.scene.clearSelection()
    window.scene.nodes["b"].setSelected(True)
    window.delete_action.trigger()
    assert "b" not in ws.network and "b" not in window.scene.nodes
    assert [c.source for c in ws.network.inputs_of("total", "values")] == ["a", "c"]
    assert ws.network.links == [] and window.scene.link_items == {}

    ws.undo_stack.undo()
    assert (list(ws.network.processors), ws.network.connections, list(ws.network.links)) == before
    assert [c.source for c in ws.network.inputs_of("total", "values")] == ["a", "b", "c"]
    assert set(window.scene.link_items) == set(before[2])
    assert set(window.scene.edges) == set(before[1])
    ws.undo_stack.redo()
    assert "b" not in ws.network and len(ws.network.connections) == 2


def test_drag_a_node_moves_the_processor_undo_redo(window, qtbot):
    ws = window.workspace
    ws.add_processor("FunctionSelector", (0, 0))
    ws.add_processor("CubicSplineProcessor", (0, 150))
    connection = ws.connect("functionSelector.volume", "cubicSplineProcessor.volume")
    edge = window.scene.edges[connection]
    drag(qtbot, window, QPointF(60, 30), QPointF(160, 70))  # grab the title, move by (100, 40)

    assert ws.network["functionSelector"].position == (100.0, 40.0)
    assert edge.path().pointAtPercent(0) == port_position(window, "functionSelector", "out", "volume")
    ws.undo_stack.undo()
    assert ws.network["functionSelector"].position == (0.0, 0.0)
    assert window.scene.nodes["functionSelector"].pos() == QPointF(0, 0)
    assert edge.path().pointAtPercent(0) == port_position(window, "functionSelector", "out", "volume")
    ws.undo_stack.redo()
    assert window.scene.nodes["functionSelector"].pos() == QPointF(100, 40)


def test_cameras_are_auto_linked_in_the_same_undo_step(window):
    ws = window.workspace
    ws.add_processor("EntryExitPoints", (0, 0))
    ws.add_processor("RayCaster", (0, 150))
    link = Link("entryExitPoints.camera", "rayCaster.camera", bidirectional=True)
    assert ws.network.links == [link] and isinstance(window.scene.link_items[link], LinkItem)
    ws.undo_stack.undo()  # one step removes the ray caster and its link
    assert list(ws.network.processors) == ["entryExitPoints"] and ws.network.links == []
    window.auto_link_action.setChecked(False)
    ws.add_processor("RayCaster", (0, 150))
    assert ws.network.links == []


def test_link_dialog_links_and_the_link_item_deletes_undo_redo(window):
    ws = window.workspace
    ws.add_processor("Number", (0, 0), id="a")
    ws.add_processor("Number", (0, 150), id="b")
    ws.add_processor("Text", (250, 0), id="t")
    ws.network.set("a.value", 3.0)
    assert link_candidates(ws.network, "a.value") == ["b.value"]  # same kind, not itself
    dialog = LinkDialog(ws, window)
    dialog.leader.setCurrentText("a.value")
    dialog.follower.setCurrentText("b.value")
    dialog.add_button.click()
    assert ws.network.links == [Link("a.value", "b.value")] and ws.network.get("b.value") == 3.0
    assert dialog.links.count() == 1

    window.scene.clearSelection()
    window.scene.link_items[Link("a.value", "b.value")].setSelected(True)
    window.delete_action.trigger()
    assert ws.network.links == [] and window.scene.link_items == {}
    ws.undo_stack.undo()
    assert ws.network.links == [Link("a.value", "b.value")]
    ws.undo_stack.undo()                       # undoing the link restores the follower's value
    assert ws.network.links == [] and ws.network.get("b.value") == 1.0
    ws.undo_stack.redo()
    assert ws.network.get("b.value") == 3.0


def test_zoom_is_clamped(window):
    for _ in range(30):
        window.zoom_in_action.trigger()
    assert window.view.transform().m11() == 4.0
    for _ in range(60):
        window.zoom_out_action.trigger()
    assert abs(window.view.transform().m11() - 0.2) < 1e-9


def test_dragging_a_type_from_the_palette_drops_it_where_released(window):
    from PySide6.QtGui import QDragEnterEvent, QDragMoveEvent, QDropEvent
    from PySide6.QtWidgets import QApplication

    palette = window.palette
    palette.search.setText("FunctionSelector")
    category = next(palette.tree.topLevelItem(i) for i in range(palette.tree.topLevelItemCount())
                    if not palette.tree.topLevelItem(i).isHidden())
    item, = [category.child(j) for j in range(category.childCount()) if not category.child(j).isHidden()]
    mime = palette.tree.mimeData([item])
    drop_at = QPointF(window.view.mapFromScene(QPointF(120, 80)))
    viewport = window.view.viewport()
    for event_type in (QDragEnterEvent, QDragMoveEvent):  # these take integer positions
        event = event_type(drop_at.toPoint(), Qt.CopyAction, mime, Qt.LeftButton, Qt.NoModifier)
        QApplication.sendEvent(viewport, event)
        assert event.isAccepted()
    QApplication.sendEvent(viewport, QDropEvent(drop_at, Qt.CopyAction, mime, Qt.LeftButton, Qt.NoModifier))
    processor = window.workspace.network["functionSelector"]
    assert abs(processor.position[0] - 120) <= 1 and abs(processor.position[1] - 80) <= 1
    assert window.inspector.processor_id == "functionSelector"
