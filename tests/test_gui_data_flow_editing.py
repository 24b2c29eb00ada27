"""Editing that follows the data flow (issue 32, item 3): processors added one after another line
up downwards and connect where unambiguous, a drop onto a taken inport replaces its connection
(one undo step), connections drawn at once go around nodes, File > New resets the zoom, Ctrl+F
searches the palette and inserts at the mouse."""

from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QCursor, QPainterPathStroker

from helpers.gui import drag, port_position
from vgraph.gui.items import NODE_HEIGHT, NODE_WIDTH
from vgraph.network import Connection


def node_rect(scene, pid) -> QRectF:
    node = scene.nodes[pid]
    return QRectF(node.x(), node.y(), NODE_WIDTH, NODE_HEIGHT)


def crossings(scene) -> list[tuple[str, str]]:
    """(connection, node) pairs where a drawn connection runs under a node not its own."""
    stroker = QPainterPathStroker()
    stroker.setWidth(2.2)
    found = []
    for connection, edge in scene.edges.items():
        stroke = stroker.createStroke(edge.mapToScene(edge.path()))
        found += [(str(connection), pid) for pid in scene.nodes
                  if pid not in (connection.source, connection.target) and stroke.intersects(node_rect(scene, pid))]
    return found


def choose(window, type_name: str) -> str:
    """What a double-click on the palette does (palette.processor_chosen); the new id."""
    window.palette.processor_chosen.emit(type_name)
    return window.inspector.processor_id


def test_processors_added_one_after_another_line_up_and_connect(window):
    ids = [choose(window, t) for t in ("VolumeSource", "EntryExitPoints", "RayCaster", "Canvas")]
    source, eep, rc, canvas = ids
    network, scene = window.workspace.network, window.scene
    tops = [network[pid].position[1] for pid in ids]
    assert tops == sorted(tops) and all(b - a >= NODE_HEIGHT for a, b in zip(tops, tops[1:]))
    assert {network[pid].position[0] for pid in ids} == {network[source].position[0]}
    # Each connected to the one before where one pairing fits (or the ports' names pair them).
    assert network.connections == [Connection(source, "volume", eep, "volume"),
                                   Connection(eep, "entry", rc, "entry"), Connection(eep, "exit", rc, "exit"),
                                   Connection(rc, "image", canvas, "image")]
    assert crossings(scene) == []
    # Adding and connecting is one undo step.
    window.workspace.undo_stack.undo()
    assert canvas not in network and len(network.connections) == 3


def test_the_selected_processor_is_the_anchor_and_a_sibling_goes_beside_it(window):
    source = choose(window, "VolumeSource")
    choose(window, "EntryExitPoints")
    window.scene.select_processor(source)
    canvas = choose(window, "Canvas")     # takes an Image: VolumeSource gives none
    network = window.workspace.network
    assert network[canvas].position[0] >= network[source].position[0] + NODE_WIDTH
    assert abs(network[canvas].position[1] - network[source].position[1]) < NODE_HEIGHT
    assert not network.connections_of(canvas)


def test_ambiguous_ports_are_left_unconnected(window):
    first = choose(window, "VolumeSource")
    window.scene.select_processor(first)
    # Four Volume inports, none named as VolumeSource's outport: which one is unclear.
    combine = choose(window, "MultiVolumeRayCaster")
    assert not window.workspace.network.connections_of(combine)


def test_dropping_onto_a_taken_inport_replaces_its_connection_in_one_undo_step(window, qtbot):
    workspace = window.workspace
    for pid, x in (("a", 0), ("b", 300)):
        workspace.add_processor("Number", (x, 0), id=pid)
    workspace.add_processor("Collect", (0, 200), id="sink")
    workspace.add_processor("Number", (600, 200), id="other")
    workspace.connect("a.value", "sink.value")
    network, stack = workspace.network, workspace.undo_stack
    inport = network["sink"].inport("value")
    assert not inport.multiple   # a single inport: taken by a.value
    steps = stack.count()
    drag(qtbot, window, port_position(window, "b", "out", "value"), port_position(window, "sink", "in", "value"))
    assert network.inputs_of("sink", "value") == [Connection("b", "value", "sink", "value")]
    assert stack.count() == steps + 1 and stack.undoText().startswith("Replace a.value -> sink.value")
    assert Connection("b", "value", "sink", "value") in window.scene.edges
    stack.undo()
    assert network.inputs_of("sink", "value") == [Connection("a", "value", "sink", "value")]
    assert set(window.scene.edges) == {Connection("a", "value", "sink", "value")}
    stack.redo()
    assert network.inputs_of("sink", "value") == [Connection("b", "value", "sink", "value")]


def test_file_new_resets_the_zoom(window):
    window.view.zoom(0.25)
    assert window.view.transform().m11() < 0.5
    window.new_action.trigger()
    assert window.view.transform().m11() == 1.0


def test_ctrl_f_searches_the_palette_and_inserts_at_the_mouse(window, qtbot):
    window.welcome.page.empty_button.click()   # from the welcome page to the (empty) editor
    viewport = window.view.viewport()
    at = QPointF(viewport.width() * 0.25, viewport.height() * 0.75).toPoint()
    QCursor.setPos(viewport.mapToGlobal(at))
    qtbot.keyClick(window.view, Qt.Key_F, Qt.ControlModifier)
    search = window.palette.search
    assert window.find_action.shortcut().toString() == "Ctrl+F"
    qtbot.waitUntil(search.hasFocus)
    qtbot.keyClicks(search, "canvas")
    qtbot.keyClick(search, Qt.Key_Return)
    pid = window.inspector.processor_id
    assert window.workspace.network[pid].type_name == "Canvas"
    centre = node_rect(window.scene, pid).center()
    asked = window.view.mapToScene(at)
    assert abs(centre.x() - asked.x()) < 1 and abs(centre.y() - asked.y()) < 1
