"""Clip planes in the GUI: Ctrl + left drag in a canvas moves the first clip plane along its normal
so that it follows the cursor (one undo step per drag, the camera untouched), says so when there
is no plane; the inspector's clip-planes editor shows, edits, adds and removes planes, and a zero
normal typed in is refused by the workspace with the processor and field named."""

import numpy as np
import pytest
from PySide6.QtCore import QSettings, Qt

from vgraph.camera import Camera
from vgraph.clipping import ClipPlane
from vgraph.gui import clip_drag
from vgraph.gui.clip_planes_editor import ClipPlanesEditor
from vgraph.gui.inspector import PropertyInspector
from vgraph.gui.workspace import Workspace

from helpers.canvas import SIZE, drag, make_view

# Orthographic down -z, 2 world units high: 1 Qt pixel = 2 / 160 world units in a 200 x 160 view
# with no frame shown (the view height is the widget's).
CAMERA = Camera(projection="orthographic", position=(0.0, 0.0, 5.0), focus=(0.0, 0.0, 0.0),
                parallel_scale=1.0, near=1.0, far=10.0)
PER_PIXEL = 2.0 / SIZE[1]


@pytest.fixture
def ws(qtbot, tmp_path):
    return Workspace(QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat))


def build(ws, planes=()):
    ws.add_processor("EntryExitPoints", (0, 0), id="eep")
    ws.add_processor("RayCaster", (0, 120), id="rc")
    ws.add_processor("Canvas", (0, 240), id="canvas")
    for source, target in (("eep.entry", "rc.entry"), ("eep.exit", "rc.exit"), ("rc.image", "canvas.image")):
        ws.connect(source, target)
    ws.set_property("eep.camera", CAMERA)
    ws.set_property("eep.clip_planes", planes)


def test_ctrl_drag_moves_the_first_plane_with_the_cursor_in_one_undo_step(ws, qtbot):
    planes = [{"normal": [1.0, 0.0, 0.0], "point": [0.1, 0.0, 0.0]}, {"normal": [0.0, 1.0, 0.0]}]
    build(ws, planes)
    view = make_view(qtbot, ws)
    count, camera = ws.undo_stack.count(), ws.network.get("rc.camera")
    states = []
    view.interacting.connect(states.append)
    drag(view, (60, 80), (100, 50), modifiers=Qt.ControlModifier)  # 40 px right, 30 up
    moved = ws.network.get("eep.clip_planes")
    # The normal is +x on screen: the plane follows the horizontal part of the drag.
    np.testing.assert_allclose(moved[0].point, (0.1 + 40 * PER_PIXEL, 0.0, 0.0), atol=1e-9)
    assert moved[0].normal == (1.0, 0.0, 0.0) and moved[1] == ClipPlane(normal=(0.0, 1.0, 0.0))
    assert ws.network.get("rc.camera") == camera  # not rotated
    assert ws.undo_stack.count() == count + 1 and states == [True, False]
    ws.undo_stack.undo()
    assert ws.network.get("eep.clip_planes")[0].point == (0.1, 0.0, 0.0)


def test_a_plane_facing_the_viewer_moves_with_vertical_drags():
    plane = ClipPlane(normal=(0.0, 0.0, 1.0), point=(0.0, 0.0, 0.0))  # faces the camera (looks down -z)
    # Up 10 pixels pushes it away from the viewer: along -z, i.e. against this normal.
    assert clip_drag.drag_distance(CAMERA, plane, 0.0, -10.0, SIZE[1]) == pytest.approx(-10 * PER_PIXEL)
    tilted = ClipPlane(normal=(0.0, -1.0, 0.0))  # -y on screen: a drag down (+dy) moves it along +normal
    assert clip_drag.drag_distance(CAMERA, tilted, 7.0, 12.0, SIZE[1]) == pytest.approx(12 * PER_PIXEL)
    perspective = Camera(position=(0.0, 0.0, 5.0), focus=(0.0, 0.0, 0.0), fov=90.0, near=1.0, far=10.0)
    # At depth 5 a 90-degree view is 10 units high.
    assert clip_drag.drag_distance(perspective, ClipPlane(normal=(1.0, 0.0, 0.0)), 16.0, 0.0, 160.0) == \
        pytest.approx(1.0)


def test_ctrl_drag_without_planes_says_so_and_changes_nothing(ws, qtbot):
    build(ws)
    view = make_view(qtbot, ws)
    count = ws.undo_stack.count()
    drag(view, (60, 80), (100, 50), modifiers=Qt.ControlModifier)
    assert view.message() == clip_drag.NO_PLANE
    assert ws.undo_stack.count() == count and ws.network.get("eep.clip_planes") == ()


def inspector_editor(ws, qtbot, messages=None):
    inspector = PropertyInspector(ws)
    qtbot.addWidget(inspector)
    if messages is not None:
        inspector.status_message.connect(messages.append)
    inspector.show_processor("eep")
    return inspector, inspector.editors["clip_planes"]


def test_the_inspector_edits_clip_planes(ws, qtbot):
    build(ws, [{"normal": [1.0, 0.0, 0.0], "point": [0.25, 0.0, 0.0]}])
    inspector, editor = inspector_editor(ws, qtbot)
    assert isinstance(editor, ClipPlanesEditor) and len(editor.rows) == 1
    assert editor.rows[0]["point"][0].value() == 0.25
    editor.rows[0]["point"][1].setValue(-0.5)
    assert ws.network.get("eep.clip_planes")[0].point == (0.25, -0.5, 0.0)
    editor.add.click()  # the second plane: the first reversed, a slab
    planes = ws.network.get("eep.clip_planes")
    assert len(planes) == 2 and planes[1].normal == (-1.0, 0.0, 0.0) and len(editor.rows) == 2
    editor.rows[0]["remove"].click()
    assert [p.normal for p in ws.network.get("eep.clip_planes")] == [(-1.0, 0.0, 0.0)] and len(editor.rows) == 1
    ws.undo_stack.undo()  # the removal
    assert len(ws.network.get("eep.clip_planes")) == 2 and len(editor.rows) == 2


def test_a_zero_normal_typed_in_is_refused_naming_processor_and_field(ws, qtbot):
    build(ws, [{"normal": [1.0, 0.0, 0.0]}])
    messages = []
    inspector, editor = inspector_editor(ws, qtbot, messages)
    editor.rows[0]["normal"][0].setValue(0.0)
    assert ws.network.get("eep.clip_planes")[0].normal == (1.0, 0.0, 0.0)
    assert editor.rows[0]["normal"][0].value() == 1.0  # shows the kept value again
    assert any("eep.clip_planes" in m and "normal must not be zero" in m for m in messages)
