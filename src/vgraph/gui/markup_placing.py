"""Markups placed and dragged with the mouse in a canvas (issue 36; docs/guide/measuring.md,
"Placing with the mouse").

Conventions:
- The markups edited are those of the selected Markups processor, else of the nearest Markups
  upstream of the canvas (between its renderer and the canvas). The kind placed is the one chosen
  the processor's ``place_kind`` property (``chosen_kind``; a ruler unless set).
- Placing (the canvas toolbar's Place, key M, ``CanvasView.set_placing``): a left click (press
  and release within ``CLICK_SLOP`` pixels) picks its pixel through the hover readout's probe
  channel (hover.py ``request``; the render process answers with ``Network.pick``): in a 3D view
  the first visible point along the pixel's ray, in iso mode the point refined on the tricubic
  surface; in a slice view the exact point on the plane. The model holds only complete markups
  (a ruler has two points), so the clicks before a kind's least count are held here and said in
  the status bar; the click that completes it adds the markup ("<kind> <n>"), and later clicks
  add points to it while its kind takes more (a point list, a closed curve), each one undo step,
  until Place is switched off (or another kind is chosen): the next placing starts a new markup.
  A click where nothing is drawn adds nothing and says so in the status bar.
- Dragging (placing or not): a left press within ``GRAB_RADIUS`` widget pixels of a point of a
  visible markup of the Markups upstream of the canvas (the one drawn in it) as the frame draws it (projected by vgraph.markups_drawing with the frame's
  camera) drags that point: each move is picked and the point goes to the picked surface point;
  the whole drag is one undo step (one merge key). A move over nothing leaves the point where it
  was and says so. In a slice view the points drawn are those in the slice (vgraph.markups_slice,
  gui/slice_markups.py), grabbed where they are drawn and moved on the slice's plane.
"""

from __future__ import annotations

import itertools

import numpy as np
from PySide6.QtCore import QObject, Qt

from vgraph.errors import VGraphError
from vgraph.gui.hover import frame_pixel
from vgraph.gui.markups_editor import chosen_kind
from vgraph.gui.slice_markups import markups_sources, network_slab
from vgraph.live.slice_clicks import PLANE_SUFFIX, slice_viewer_for
from vgraph.live.upstream import nearest_upstream, property_of_type
from vgraph.markups import POINT_COUNTS, Markup, Markups, free_name
from vgraph.markups_drawing import MarkupView
from vgraph.markups_slice import slice_reach
from vgraph.properties import MarkupsProperty

CLICK_SLOP = 3       # widget pixels: a press and release closer than this is a click
GRAB_RADIUS = 6.0    # widget pixels: a press this close to a drawn point drags it
NO_MARKUPS = ("no Markups processor to place in: select one, or connect one between the renderer and "
              "this canvas")


def markups_address(network, canvas_id: str, selected: str | None) -> str | None:
    """'id.markups' of the selected Markups processor, else of the nearest upstream of the canvas;
    a property that follows another through a link (a LineProfile's) stands for its leader, where
    the markups are edited (an edit of the follower would be overwritten by the leader's next)."""
    found = None
    if selected in network.processors:
        found = property_of_type(MarkupsProperty)(network[selected], selected)
    if found is None:
        found = nearest_upstream(network, canvas_id, property_of_type(MarkupsProperty))
    return None if found is None else leader_of(network, found)


def leader_of(network, address: str) -> str:
    """The property ``address`` follows through a link (followed back to the first), or itself."""
    seen = {address}
    while True:
        leader = next((link.source for link in network.links if link.target == address), None)
        if leader is None or leader in seen:
            return address
        seen.add(leader)
        address = leader


def picked_point(answer) -> tuple[float, float, float] | None:
    """The world point a pick answer places: the tricubic surface point in iso mode, else the
    point; None where nothing is drawn."""
    result = answer.result
    if result is None or not result.hit:
        return None
    point = result.surface.point if result.surface is not None else result.point
    return tuple(float(v) for v in point)


def miss_reason(answer) -> str:
    return answer.error if answer.result is None else f"{answer.result.canvas}: {answer.result.reason}"


def place_point(markups: Markups, kind: str, current: str | None, held: tuple, point):
    """One click's point: (new markups or None when nothing changes yet, the markup being
    placed, the points held). Adds to ``current`` while it is of ``kind`` and takes more points;
    else holds the point until the kind's least count, then adds a new markup."""
    low, high = POINT_COUNTS[kind]
    if current in markups.names and markups[current].kind == kind and len(markups[current].points) < high:
        markup = markups[current]
        return markups.with_markup(markup.model_copy(update={"points": (*markup.points, point)})), current, ()
    held = (*held, point)
    if len(held) < low:
        return None, None, held
    name = free_name(markups, kind)
    return markups.with_markup(Markup(name=name, kind=kind, points=held)), name, ()


def moved_point(markups: Markups, name: str, index: int, point) -> Markups:
    """``markups`` with point ``index`` of markup ``name`` at ``point`` (validated: a refused
    markup raises ValueError)."""
    markup = markups[name]
    points = list(markup.points)
    points[index] = point
    return markups.with_markup(Markup(name=name, kind=markup.kind, points=tuple(points), visible=markup.visible))


def nearest_drawn_point(markups: Markups, view: MarkupView, pixel, radius: float):
    """(markup name, point index) of the visible markups' point drawn nearest to frame ``pixel``
    (x, y) within ``radius`` frame pixels, or None."""
    best, best_distance = None, radius
    for markup in markups.markups:
        if not markup.visible:
            continue
        pixels, depth = view.project(markup.array)
        inside = depth >= view.camera.planes()[0]
        distances = np.hypot(pixels[:, 0] - pixel[0], pixels[:, 1] - pixel[1])
        for index in np.flatnonzero(inside & (distances <= best_distance)):
            best, best_distance = (markup.name, int(index)), float(distances[index])
    return best


def frame_camera(network, cameras: dict, processor_id: str):
    """The concrete camera of the last frame for the Markups ``processor_id``: its own, else the
    nearest upstream processor's (its camera is linked to the renderer's), or None."""
    def known(_processor, pid):
        return f"{pid}.camera" if f"{pid}.camera" in cameras else None
    address = nearest_upstream(network, processor_id, known, include_start=True)
    return None if address is None else cameras[address]


class MarkupPlacer(QObject):
    """The mouse's markups: placing clicks and point drags of every CanvasView it is given."""

    _keys = itertools.count(1)

    def __init__(self, window, workspace, hover):
        super().__init__(window)
        self.window, self.workspace, self.hover = window, workspace, hover
        self.current: str | None = None    # the markup being placed (its name)
        self.held: tuple = ()              # points clicked for a markup not complete yet
        self._for: tuple | None = None     # (markups address, kind) the held points are for

    def restart(self) -> None:
        """Forget the markup being placed and the points held: the next click starts a new one."""
        self.current, self.held, self._for = None, (), None

    def say(self, text: str) -> None:
        self.window.statusBar().showMessage(text)

    def selected(self) -> str | None:
        inspector = getattr(self.window, "inspector", None)
        return getattr(inspector, "processor_id", None)

    # --- the mouse (canvas_mouse.py hands presses here first) -----------------------------------
    def begin(self, view, event) -> dict | None:
        """A gesture for a left press without modifiers: a point drag near a drawn point, else a
        placing click while placing; None: not for markups."""
        if event.button() != Qt.LeftButton or event.modifiers() & (Qt.ShiftModifier | Qt.ControlModifier):
            return None
        network = self.workspace.network
        address = markups_address(network, view.canvas_id, self.selected())
        base = {"button": event.button(), "start": event.position(), "active": False, "address": address,
                "key": ("markups", next(self._keys))}
        grabbed = self._grab(view, event.position())
        if grabbed is not None:
            return {**base, "mode": "markup_point", "address": grabbed[0], "name": grabbed[1], "index": grabbed[2]}
        if not view.placing:
            return None
        return {**base, "mode": "markup_place"}

    def move(self, view, drag, event) -> None:
        if drag["mode"] != "markup_point":
            return
        if not drag["active"] and (event.position() - drag["start"]).manhattanLength() < CLICK_SLOP:
            return
        drag["active"] = True
        self.hover.request(view, event.position(), lambda answer: self._drag_answer(drag, answer), key=drag["key"])

    def end(self, view, drag, event) -> None:
        if drag["mode"] == "markup_point":
            if drag["active"]:
                self.move(view, drag, event)  # the release point is the last one
            return
        if (event.position() - drag["start"]).manhattanLength() >= CLICK_SLOP:
            self.say("placing markups: click without moving to place a point")
            return
        if drag["address"] is None:
            self.say(NO_MARKUPS)
            return
        if not self.hover.request(view, event.position(), lambda answer: self._click_answer(drag, answer)):
            self.say(f"{view.canvas_id}: click on the frame to place a point")

    # --- answers --------------------------------------------------------------------------------
    def _click_answer(self, drag, answer) -> None:
        point = picked_point(answer)
        if point is None:
            self.say(f"nothing placed: {miss_reason(answer)}")
            return
        address = drag["address"]
        processor = self.workspace.network.processors.get(address.split(".")[0])
        if processor is None:
            return
        kind = chosen_kind(processor)
        if self._for != (address, kind):
            self._for, self.current, self.held = (address, kind), None, ()
        markups = self.workspace.network.get(address)
        try:
            changed, self.current, self.held = place_point(markups, kind, self.current, self.held, point)
            if changed is not None:
                self.workspace.set_property(address, changed)
        except (VGraphError, ValueError) as error:
            self.held = ()
            self.say(f"{address}: {error}")
            return
        self.say(self._placed_text(kind, point))

    def _placed_text(self, kind: str, point) -> str:
        where = "(" + ", ".join(f"{v:.2f}" for v in point) + ")"
        if self.held:
            return (f"{kind.replace('_', ' ')}: point {len(self.held)} of {POINT_COUNTS[kind][0]} at {where}; "
                    f"click the next")
        return f"{self.current}: point at {where}"

    def _drag_answer(self, drag, answer) -> None:
        point = picked_point(answer)
        if point is None:
            self.say(f"the point stays: {miss_reason(answer)}")
            return
        address = drag["address"]
        try:
            markups = moved_point(self.workspace.network.get(address), drag["name"], drag["index"], point)
            self.workspace.set_property(address, markups, merge=drag["key"])
        except (VGraphError, ValueError, KeyError) as error:
            self.say(f"{address}: {error}")
            return
        self.say(f"{drag['name']}: point {drag['index'] + 1} at (" + ", ".join(f"{v:.2f}" for v in point) + ")")

    # --- grabbing -------------------------------------------------------------------------------
    def _grab(self, view, position):
        """(markups address, name, index) of the drawn point under widget ``position``, or None:
        in a 3D view the points the Markups upstream of the canvas draws, in a slice view those
        of every Markups in the slice."""
        if frame_pixel(view, position) is None:
            return None
        network = self.workspace.network
        viewer_id = slice_viewer_for(network, view.canvas_id)
        if viewer_id is not None:
            return self._grab_in_slice(view, viewer_id, position)
        address = nearest_upstream(network, view.canvas_id, property_of_type(MarkupsProperty))  # drawn here
        found = self._grab_in_3d(view, address, position) if address is not None else None
        return None if found is None else (address, *found)

    def _grab_in_3d(self, view, address: str, position):
        pixel, frame = frame_pixel(view, position), view.frame()
        network = self.workspace.network
        camera = frame_camera(network, view.view_cameras(), address.split(".")[0])
        markups = network.get(address)
        if camera is None or not len(markups) or camera.near is None or camera.far is None:
            return None
        height, width = frame.shape[:2]
        radius = GRAB_RADIUS * width / max(view.image_rect().width(), 1.0)
        return nearest_drawn_point(markups, MarkupView(camera, (width, height)), pixel, radius)

    def _grab_in_slice(self, view, viewer_id: str, position):
        plane = view.view_cameras().get(viewer_id + PLANE_SUFFIX)
        if plane is None:
            return None
        rect = view.image_rect()
        reach = slice_reach(plane, network_slab(self.workspace.network, viewer_id))
        where = (position.x(), position.y())
        for address, markups, _colour, _units in markups_sources(self.workspace.network):
            found = nearest_slice_point(markups, plane, reach, where,
                                        (rect.left(), rect.top(), rect.width(), rect.height()))
            if found is not None:
                return (address, *found)
        return None


def nearest_slice_point(markups: Markups, plane, reach: float, widget, rect, radius: float = GRAB_RADIUS):
    """(markup name, point index) of the visible markups' point in the slice drawn nearest to
    ``widget`` (x, y) within ``radius`` widget pixels, or None; ``rect`` is where the frame is
    drawn (left, top, width, height)."""
    left, top, width, height = rect
    best, best_distance = None, radius
    for markup in markups.markups:
        if not markup.visible:
            continue
        points = markup.array
        inside = np.abs((points - np.asarray(plane.centre)) @ np.asarray(plane.normal)) <= reach
        uv = plane.uv_of(points)
        x, y = left + uv[:, 0] * width, top + (1.0 - uv[:, 1]) * height
        distances = np.hypot(x - widget[0], y - widget[1])
        for index in np.flatnonzero(inside & (distances <= best_distance)):
            best, best_distance = (markup.name, int(index)), float(distances[index])
    return best
