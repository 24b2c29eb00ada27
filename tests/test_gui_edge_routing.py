"""Connections drawn around unrelated nodes, and new processors placed where they hide nothing
(issue #17, item 5): the drawn path (the stroke a user sees) is tested against the nodes'
rectangles with Qt's own path geometry."""

import pytest
from PySide6.QtCore import QPointF, QRectF
from PySide6.QtGui import QPainterPath, QPainterPathStroker

from vgraph.gui.edge_routing import Box, default_curve, route, segment_hits
from vgraph.gui.items import NODE_HEIGHT, NODE_WIDTH, connection_path
from vgraph.gui.scene import NetworkScene
from vgraph.gui.workspace import Workspace
from vgraph.network import Connection

EDGE = Connection("a", "value", "sink", "value")


@pytest.fixture
def scene(qtbot, tmp_path):
    """a (Number) at the top, sink (Collect) below it, a.value -> sink.value, and a third node
    `mid` placed by each test."""
    from PySide6.QtCore import QSettings
    workspace = Workspace(QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat))
    scene = NetworkScene(workspace)
    workspace.add_processor("Number", (0, 0), id="a")
    workspace.add_processor("Collect", (0, 300), id="sink")
    workspace.connect("a.value", "sink.value")
    yield scene
    scene.detach()


def drawn(edge) -> QPainterPath:
    """What the user sees of a connection: its stroke at the drawn pen width."""
    stroker = QPainterPathStroker()
    stroker.setWidth(2.2)
    return stroker.createStroke(edge.mapToScene(edge.path()))


def node_rect(scene, pid) -> QRectF:
    node = scene.nodes[pid]
    return QRectF(node.x(), node.y(), NODE_WIDTH, NODE_HEIGHT)


def same_path(p: QPainterPath, q: QPainterPath) -> bool:
    ends = [(e.x, e.y, e.type) for e in (p.elementAt(i) for i in range(p.elementCount()))]
    return ends == [(e.x, e.y, e.type) for e in (q.elementAt(i) for i in range(q.elementCount()))]


def ports(scene):
    edge = scene.edges[EDGE]
    return edge.source.scenePos(), edge.target.scenePos()


def test_a_connection_goes_around_a_node_between_its_ends(scene):
    scene.workspace.add_processor("Number", (0, 150), id="mid")
    edge = scene.edges[EDGE]
    start, end = ports(scene)
    # The default curve would run straight through it (the case being fixed).
    assert connection_path(start, end).intersects(node_rect(scene, "mid"))
    assert not drawn(edge).intersects(node_rect(scene, "mid"))
    assert edge.route.avoided == {"mid"}
    # It still joins the two ports, leaving downwards and arriving from above.
    path = edge.path()
    first, last = path.elementAt(0), path.elementAt(path.elementCount() - 1)
    assert (first.x, first.y) == (start.x(), start.y()) and (last.x, last.y) == (end.x(), end.y())
    assert edge.route.points[1][1] > start.y() and edge.route.points[-2][1] < end.y()
    # And runs under neither of its own nodes.
    for pid in ("a", "sink"):
        assert not drawn(edge).intersects(node_rect(scene, pid).adjusted(2, 2, -2, -2))


def test_a_connection_with_nothing_in_its_way_keeps_the_curve(scene):
    scene.workspace.add_processor("Number", (400, 150), id="mid")  # beside, not between
    edge = scene.edges[EDGE]
    assert edge.route.curved and not edge.route.avoided
    assert same_path(edge.path(), connection_path(*ports(scene)))


def test_moving_the_node_away_and_back_reroutes_the_connection(scene):
    workspace = scene.workspace
    workspace.add_processor("Number", (0, 150), id="mid")
    edge = scene.edges[EDGE]
    assert not edge.route.curved
    workspace.move({"mid": (420.0, 150.0)})
    assert same_path(edge.path(), connection_path(*ports(scene)))
    workspace.undo_stack.undo()          # back between the two: around it again
    assert not edge.route.curved and not drawn(edge).intersects(node_rect(scene, "mid"))
    scene.nodes["mid"].setPos(30.0, 170.0)  # as a mouse drag moves it (the item itself)
    assert not edge.route.curved and not drawn(edge).intersects(node_rect(scene, "mid"))
    scene.nodes["mid"].setPos(600.0, 170.0)
    assert edge.route.curved


def test_moving_an_end_node_reroutes_around_the_others(scene):
    workspace = scene.workspace
    workspace.add_processor("Number", (300, 150), id="mid")
    edge = scene.edges[EDGE]
    assert edge.route.curved
    workspace.move({"sink": (300.0, 300.0)})  # now the curve from a would cross mid
    assert not drawn(edge).intersects(node_rect(scene, "mid"))
    assert "mid" in edge.route.avoided


def test_removing_the_node_in_the_way_straightens_the_connection(scene):
    scene.workspace.add_processor("Number", (0, 150), id="mid")
    scene.workspace.remove(["mid"], [], [])
    assert same_path(scene.edges[EDGE].path(), connection_path(*ports(scene)))


def test_several_nodes_in_the_way_in_a_column_and_beside_it(scene):
    workspace = scene.workspace
    workspace.move({"sink": (0.0, 600.0)})
    for i, (x, y) in enumerate([(0, 130), (-30, 260), (40, 390), (-200, 260), (200, 390)]):
        workspace.add_processor("Number", (x, y), id=f"n{i}")
    edge = scene.edges[EDGE]
    assert edge.route.avoided
    for i in range(5):
        assert not drawn(edge).intersects(node_rect(scene, f"n{i}")), f"n{i}"


def test_a_new_processor_covers_no_node_and_no_connection(scene):
    workspace = scene.workspace
    workspace.add_processor("Number", (0, 150), id="mid")
    edge = scene.edges[EDGE]
    # Asked for the middle of the routed connection's vertical run: that spot is taken.
    (x, top), (_, bottom) = edge.route.points[2], edge.route.points[3]
    for n in range(4):  # one after another, each must find its own spot
        workspace.add_processor("Number", scene.free_position(QPointF(x, (top + bottom) / 2)), id=f"new{n}")
        rect = node_rect(scene, f"new{n}")
        assert not any(rect.intersects(node_rect(scene, pid)) for pid in scene.nodes if pid != f"new{n}")
        assert not any(drawn(e).intersects(rect) for e in scene.edges.values())
        assert edge.route.avoided == {"mid"}     # nothing had to move out of its way


def test_free_position_keeps_the_asked_spot_when_it_is_free_and_lines_up_downwards(scene):
    x, y = scene.free_position(QPointF(900.0, 100.0))
    assert (x, y) == (900.0 - NODE_WIDTH / 2, 100.0 - NODE_HEIGHT / 2)
    scene.workspace.add_processor("Number", (x, y), id="first")
    x2, y2 = scene.free_position(QPointF(900.0, 100.0))
    assert x2 == x and y2 >= y + NODE_HEIGHT


def test_dropping_a_processor_on_a_connection_puts_it_beside(window):
    """The palette's drop lands the node where released, unless it would hide a connection."""
    from PySide6.QtCore import Qt
    from PySide6.QtGui import QDragEnterEvent, QDragMoveEvent, QDropEvent
    from PySide6.QtWidgets import QApplication
    workspace, scene = window.workspace, window.scene
    workspace.add_processor("Number", (0, 0), id="a")
    workspace.add_processor("Collect", (0, 300), id="sink")
    workspace.connect("a.value", "sink.value")
    palette = window.palette
    palette.search.setText("FunctionSelector")
    category = next(palette.tree.topLevelItem(i) for i in range(palette.tree.topLevelItemCount())
                    if not palette.tree.topLevelItem(i).isHidden())
    item, = [category.child(j) for j in range(category.childCount()) if not category.child(j).isHidden()]
    mime, viewport = palette.tree.mimeData([item]), window.view.viewport()
    on_the_edge = QPointF(window.view.mapFromScene(QPointF(84 - 20, 150)))  # the corner released there
    for event_type in (QDragEnterEvent, QDragMoveEvent):  # as the drag reaches the editor
        QApplication.sendEvent(viewport, event_type(on_the_edge.toPoint(), Qt.CopyAction, mime, Qt.LeftButton,
                                                    Qt.NoModifier))
    QApplication.sendEvent(viewport, QDropEvent(on_the_edge, Qt.CopyAction, mime, Qt.LeftButton, Qt.NoModifier))
    rect = node_rect(scene, "functionSelector")
    assert not drawn(scene.edges[EDGE]).intersects(rect)
    assert not any(rect.intersects(node_rect(scene, pid)) for pid in ("a", "sink"))
    # Near where it was dropped (the nearest free spot), not thrown far away.
    assert abs(rect.left() - 64) < 2 * NODE_WIDTH and abs(rect.top() - 150) < 3 * NODE_HEIGHT


# --- the geometry on its own ---------------------------------------------------------------------
def test_segment_hits_agrees_with_qt_on_random_segments():
    import random
    rng = random.Random(7)
    box = Box(10.0, 20.0, 60.0, 45.0)
    rect = QRectF(10.0, 20.0, 50.0, 25.0)
    for _ in range(2000):
        p = (rng.uniform(-20, 90), rng.uniform(0, 70))
        q = (rng.uniform(-20, 90), rng.uniform(0, 70))
        stroke = QPainterPathStroker()
        stroke.setWidth(1e-3)
        line = QPainterPath(QPointF(*p))
        line.lineTo(QPointF(*q))
        inner = rect.adjusted(0.01, 0.01, -0.01, -0.01)  # away from the boundary, where both may differ
        outer = rect.adjusted(-0.01, -0.01, 0.01, 0.01)
        if stroke.createStroke(line).intersects(inner):
            assert segment_hits(p, q, box), (p, q)
        elif not stroke.createStroke(line).intersects(outer):
            assert not segment_hits(p, q, box), (p, q)


def test_default_curve_samples_lie_on_the_drawn_cubic():
    start, end = (10.0, 20.0), (200.0, 330.0)
    path = connection_path(QPointF(*start), QPointF(*end))
    stroker = QPainterPathStroker()
    stroker.setWidth(0.05)
    stroke = stroker.createStroke(path)
    for x, y in default_curve(start, end):
        assert stroke.intersects(QRectF(x - 0.05, y - 0.05, 0.1, 0.1))


def test_routing_a_crowded_grid_finds_clear_paths():
    """Fifty nodes 52 units apart side by side, 68 above each other: every connection between
    two of them gets through without crossing a third."""
    boxes = {i: Box.of((i % 7) * 220.0, (i // 7) * 130.0, NODE_WIDTH, NODE_HEIGHT) for i in range(50)}
    for a, b in [(0, 48), (3, 45), (49, 1), (10, 12), (21, 27), (6, 42)]:
        source, target = boxes[a], boxes[b]
        others = {k: v for k, v in boxes.items() if k not in (a, b)}
        course = route((source.left + 84, source.bottom), (target.left + 84, target.top), others)
        assert not any(course.crosses(box) for box in others.values()), (a, b)


def test_two_connections_around_the_same_node_take_different_lanes(scene):
    """Both go round `mid` on the same side: in different lanes, so each can be followed."""
    workspace = scene.workspace
    workspace.add_processor("Number", (0, -150), id="b")
    workspace.add_processor("Collect", (0, 450), id="sink2")
    workspace.add_processor("Number", (0, 150), id="mid")
    workspace.connect("b.value", "sink2.value")
    first, second = scene.edges[EDGE], scene.edges[Connection("b", "value", "sink2", "value")]
    assert first.route.avoided == {"mid"} and second.route.avoided == {"a", "mid", "sink"}

    def channel(edge):   # the x of the longest vertical run
        points = edge.route.points
        runs = [(abs(q[1] - p[1]), p[0]) for p, q in zip(points, points[1:]) if p[0] == q[0]]
        return max(runs)[1]
    assert abs(channel(first) - channel(second)) >= 4.0
    for edge in (first, second):
        for pid in edge.route.avoided:
            assert not drawn(edge).intersects(node_rect(scene, pid)), pid


def test_a_connection_to_an_inport_above_goes_around_its_own_nodes(scene):
    """Side by side (the inport higher than the outport): the curve would cut through both nodes."""
    scene.workspace.move({"sink": (260.0, 0.0)})
    edge = scene.edges[EDGE]
    start, end = ports(scene)
    assert connection_path(start, end).intersects(node_rect(scene, "sink"))   # the old drawing
    assert not edge.route.curved
    for pid in ("a", "sink"):   # a little inside: the path starts and ends on their edges
        assert not drawn(edge).intersects(node_rect(scene, pid).adjusted(3, 3, -3, -3)), pid
    path = edge.path()
    first, last = path.elementAt(0), path.elementAt(path.elementCount() - 1)
    assert (first.x, first.y) == (start.x(), start.y()) and (last.x, last.y) == (end.x(), end.y())
    scene.workspace.move({"sink": (0.0, 300.0)})   # back below: the curve again
    assert same_path(edge.path(), connection_path(*ports(scene)))


def test_a_connection_up_a_tight_column_goes_around_the_nodes_in_it():
    """Nodes added one under another 31 units apart (less than a stub and its margins): the
    connection from the third to the first (an inport above) used to keep the curve through the
    second until a node moved (issue 32, item 3); the stubs now shorten to fit."""
    column = {pid: Box.of(0, y, NODE_WIDTH, NODE_HEIGHT) for pid, y in (("rc", 0), ("vs", 93), ("eep", 186), ("canvas", 279))}
    start, end = (40.0, 186.0 + NODE_HEIGHT), (40.0, 0.0)
    others = {pid: box for pid, box in column.items() if pid not in ("rc", "eep")}
    course = route(start, end, others, ends=(column["eep"], column["rc"]))
    assert not course.curved and "vs" in course.avoided
    assert not any(segment_hits(p, q, box) for p, q in zip(course.points, course.points[1:])
                   for box in column.values() if box not in (column["eep"], column["rc"]))
    for p, q in zip(course.points[1:-2], course.points[2:-1]):   # the middle legs: clear of their own nodes
        assert not segment_hits(p, q, column["eep"]) and not segment_hits(p, q, column["rc"])
