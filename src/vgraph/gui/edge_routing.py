"""Where the network editor draws a connection, and where it puts a new node: pure geometry.

A connection is normally a cubic curve leaving its outport downwards and entering its inport from
above (``default_curve``). When that curve would run under an unrelated node, ``route`` replaces it
by an orthogonal path through a free channel beside or between the nodes in the way (drawn with
rounded corners by items.py). ``free_spot`` finds a place for a new node that covers neither a node
nor a connection.

Conventions:
- Scene units, y downwards; a point is an ``(x, y)`` tuple; nodes are ``Box`` es.
- Obstacles are keyed by processor id, so that the scene knows which nodes a route avoided and
  re-routes only the connections a moved node can affect (``Route.avoided``).
- No Qt here: every function is cheap enough to run for every mouse move of a node drag in a
  network of ~50 nodes (a curve is tested against the boxes its control hull overlaps only, and
  the route search stops at the first clear candidate in order of cost).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Iterable, Mapping, Sequence

Point = tuple[float, float]

MARGIN = 12.0        # clearance kept between a connection and a node it passes
STUB = 22.0          # a route leaves an outport / enters an inport vertically for this long
BEND_COST = 30.0     # a bend costs as much as this much extra length: prefer fewer corners
CURVE_SAMPLES = 20   # segments of the polyline that stands for the cubic in hit tests
LANE_STEP = 5.0      # routes in lanes this far apart (see ``route``'s lane), so they do not merge
MAX_CHECKS = 5000    # route candidates tested at most; beyond, the default curve is kept
SHORTLIST = 4        # heights tried for each horizontal leg besides the stub's own


@dataclass(frozen=True)
class Box:
    left: float
    top: float
    right: float
    bottom: float

    @classmethod
    def of(cls, x: float, y: float, width: float, height: float) -> "Box":
        return cls(x, y, x + width, y + height)

    def inflated(self, margin: float) -> "Box":
        return Box(self.left - margin, self.top - margin, self.right + margin, self.bottom + margin)

    def overlaps(self, other: "Box") -> bool:
        """Interiors overlap (boxes that only touch do not)."""
        return (self.left < other.right and other.left < self.right
                and self.top < other.bottom and other.top < self.bottom)


@dataclass(frozen=True)
class Route:
    """How one connection is drawn.

    ``curved``: the default cubic from the first point to the last (``points`` samples it, for hit
    tests); otherwise the orthogonal polyline ``points``. ``avoided``: the obstacles the default
    curve would have crossed (a route must be redone when one of them moves)."""
    points: tuple[Point, ...]
    curved: bool
    avoided: frozenset = field(default_factory=frozenset)

    @cached_property
    def hull(self) -> Box:
        return bounds(self.points)

    def crosses(self, box: Box) -> bool:
        return self.hull.overlaps(box) and polyline_hits(self.points, box)


# --- the default curve ---------------------------------------------------------------------------
def curve_controls(start: Point, end: Point) -> tuple[Point, Point]:
    """The cubic's inner control points: straight down from the outport, straight into the inport."""
    bend = max(40.0, abs(end[1] - start[1]) * 0.5)
    return (start[0], start[1] + bend), (end[0], end[1] - bend)


def default_curve(start: Point, end: Point, samples: int = CURVE_SAMPLES) -> tuple[Point, ...]:
    (ax, ay), (bx, by), (cx, cy), (dx, dy) = start, *curve_controls(start, end), end
    points = []
    for i in range(samples + 1):
        t = i / samples
        u = 1.0 - t
        w0, w1, w2, w3 = u * u * u, 3 * u * u * t, 3 * u * t * t, t * t * t
        points.append((w0 * ax + w1 * bx + w2 * cx + w3 * dx, w0 * ay + w1 * by + w2 * cy + w3 * dy))
    return tuple(points)


# --- hit tests -----------------------------------------------------------------------------------
def bounds(points: Iterable[Point]) -> Box:
    xs, ys = zip(*points)
    return Box(min(xs), min(ys), max(xs), max(ys))


def segment_hits(p: Point, q: Point, box: Box) -> bool:
    """Does the segment pq pass through the box's interior? (Liang-Barsky clipping.)"""
    (x0, y0), (x1, y1) = p, q
    if max(x0, x1) <= box.left or min(x0, x1) >= box.right or max(y0, y1) <= box.top or min(y0, y1) >= box.bottom:
        return False
    dx, dy = x1 - x0, y1 - y0
    t0, t1 = 0.0, 1.0
    for step, distance in ((-dx, x0 - box.left), (dx, box.right - x0), (-dy, y0 - box.top), (dy, box.bottom - y0)):
        if step == 0.0:
            if distance <= 0.0:   # parallel to this side and outside it (or on it)
                return False
            continue
        t = distance / step
        if step < 0.0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
        if t0 >= t1:
            return False
    return True


def polyline_hits(points: Sequence[Point], box: Box) -> bool:
    return any(segment_hits(points[i], points[i + 1], box) for i in range(len(points) - 1))


def boxes_hit(points: Sequence[Point], boxes: Mapping[object, Box]) -> frozenset:
    """The keys of the boxes the polyline passes through."""
    hull = bounds(points)
    return frozenset(key for key, box in boxes.items() if hull.overlaps(box) and polyline_hits(points, box))


# --- routing -------------------------------------------------------------------------------------
def route(start: Point, end: Point, obstacles: Mapping[object, Box], margin: float = MARGIN,
          lane: float = 0.0, ends: tuple[Box, Box] | None = None) -> Route:
    """The default curve if it clears every obstacle (by ``margin``), else the cheapest clear
    orthogonal route: down from ``start``, across to a vertical channel, along it, across to
    above ``end`` and down into it. Keeps the curve when no candidate is clear (a crowded spot).

    ``ends``: the boxes of the connection's own two nodes (source, target). The curve may pass
    close to them but not through them (it does when the inport is above the outport); a route
    keeps the margin from them too, except along its first and last legs, which start on them.

    ``lane`` (>= 0) moves the route's channel and legs that much further from the nodes they pass
    (and its stubs longer): connections given different lanes do not run on top of each other
    where they take the same channel."""
    curve = default_curve(start, end)
    grown = {key: box.inflated(margin) for key, box in obstacles.items()}
    hit = boxes_hit(curve, grown)
    through_own = ends is not None and any(polyline_hits(curve, box) for box in ends)
    if not hit and not through_own:
        return Route(curve, True)
    others = list(grown.values())
    source, target = [box.inflated(margin) for box in ends] if ends is not None else ([], [])
    first = _LegTest(others + ([target] if ends else []))   # leaves the source: may touch it
    last = _LegTest(others + ([source] if ends else []))    # enters the target
    middle = _LegTest(others + ([source, target] if ends else []))
    (x0, y0), (x1, y1) = start, end
    for _, a, b, c in sorted(_candidates(start, end, middle.boxes, lane))[:MAX_CHECKS]:
        # The legs beside the stubs may pass within the margin of their own node (a stub shortened
        # to fit between its port and the next node), never through it: a > y0 and b < y1.
        if (first.vertical(x0, y0, a) and first.horizontal(a, x0, c) and middle.vertical(c, a, b)
                and last.horizontal(b, c, x1) and last.vertical(x1, b, y1)):
            return Route(_simplified([start, (x0, a), (c, a), (c, b), (x1, b), end]), False, hit)
    return Route(curve, True, hit)


class _LegTest:
    """Is an axis-parallel leg clear of every box? Remembered per leg: the candidates of one
    route share most of their legs, so a search tests each leg once."""

    def __init__(self, boxes: list[Box]):
        self.boxes = [(b.left, b.top, b.right, b.bottom) for b in boxes]  # tuples: the tests' inner loop
        self.known: dict[tuple, bool] = {}

    def vertical(self, x: float, y_from: float, y_to: float) -> bool:
        key = ("v", x, y_from, y_to)
        if key not in self.known:
            low, high = min(y_from, y_to), max(y_from, y_to)
            self.known[key] = not any(l < x < r and t < high and low < b for l, t, r, b in self.boxes)
        return self.known[key]

    def horizontal(self, y: float, x_from: float, x_to: float) -> bool:
        key = ("h", y, x_from, x_to)
        if key not in self.known:
            low, high = min(x_from, x_to), max(x_from, x_to)
            self.known[key] = not any(t < y < b and l < high and low < r for l, t, r, b in self.boxes)
        return self.known[key]


def _candidates(start: Point, end: Point, boxes: Iterable[tuple], lane: float) -> list[tuple[float, float, float, float]]:
    """(cost, a, b, c) of every route through a vertical channel x = c at a node's side (or below
    a port), leaving the outport's stub at height a and reaching the inport's at height b.
    Costed without building the polylines: most are never tested."""
    boxes = [Box(*box) for box in boxes]
    (x0, y0), (x1, y1) = start, end
    # A stub is shortened to half the gap when a node lies closer than the stub below the outport
    # (above the inport): a column of nodes added one under another leaves less than a stub.
    below = [box.top for box in boxes if box.left < x0 < box.right and box.top > y0]
    above = [box.bottom for box in boxes if box.left < x1 < box.right and box.bottom < y1]
    leave = min([y0 + STUB + lane] + [(y0 + top) / 2 for top in below])
    enter = max([y1 - STUB - lane] + [(y1 + bottom) / 2 for bottom in above])
    channels = {x0, x1}
    for box in boxes:
        channels.update((box.left - lane, box.right + lane))
    # The leg from the outport runs at the stub's height or just below a node under it; the leg
    # into the inport at the stub's height or just above a node over it. The nearest few suffice.
    lows = [leave] + sorted(b.bottom + lane for b in boxes if b.bottom + lane > leave)[:SHORTLIST]
    highs = [enter] + sorted((b.top - lane for b in boxes if b.top - lane < enter), reverse=True)[:SHORTLIST]
    found = []
    for a in lows:
        for b in highs:
            for c in channels:
                legs = ((0, a - y0), (1, c - x0), (0, b - a), (1, x1 - c), (0, y1 - b))
                turns = [(axis, d > 0) for axis, d in legs if abs(d) > 1e-6]
                bends = sum(1 for i in range(1, len(turns)) if turns[i] != turns[i - 1])
                found.append((sum(abs(d) for _, d in legs) + BEND_COST * bends, a, b, c))
    return found


def _simplified(points: list[Point]) -> tuple[Point, ...]:
    """Without repeated points and without the middle one of three on a line."""
    kept: list[Point] = []
    for p in points:
        if kept and math.isclose(p[0], kept[-1][0]) and math.isclose(p[1], kept[-1][1]):
            continue
        if len(kept) >= 2 and _collinear(kept[-2], kept[-1], p):
            kept[-1] = p
        else:
            kept.append(p)
    return tuple(kept)


def _collinear(a: Point, b: Point, c: Point) -> bool:
    same_x = math.isclose(a[0], b[0]) and math.isclose(b[0], c[0])
    same_y = math.isclose(a[1], b[1]) and math.isclose(b[1], c[1])
    return same_x or same_y


def _length(points: Sequence[Point]) -> float:
    return sum(math.dist(points[i], points[i + 1]) for i in range(len(points) - 1))


# --- placing new nodes ---------------------------------------------------------------------------
def free_spot(preferred: Point, size: tuple[float, float], nodes: Iterable[Box],
              paths: Iterable[Sequence[Point]], margin: float = 24.0, reach: int = 14) -> Point:
    """The top-left corner nearest ``preferred`` (spots below it first: new nodes line up
    downwards, as data flows) where a node of ``size``, grown by ``margin``, overlaps no node and
    no connection. Searches a grid of ``reach`` steps each way, then falls back to below everything."""
    width, height = size
    nodes = [n.inflated(margin) for n in nodes]
    paths = [(bounds(p), p) for p in paths if len(p) >= 2]
    step_x, step_y = width / 4, height / 2
    offsets = [(i * step_x, j * step_y) for i in range(-reach, reach + 1) for j in range(-reach, reach + 1)]
    # Distance, with a small bias for spots below and to the right over those above and to the left.
    offsets.sort(key=lambda o: (math.hypot(o[0], o[1] * 1.25 if o[1] < 0 else o[1]) + (1e-3 if o[0] < 0 else 0)))
    for dx, dy in offsets:
        spot = Box.of(preferred[0] + dx, preferred[1] + dy, width, height)
        if _is_free(spot, nodes, paths, margin):
            return spot.left, spot.top
    lowest = max([n.bottom for n in nodes] + [b.bottom for b, _ in paths] + [preferred[1] - margin])
    return preferred[0], lowest + margin


def _is_free(spot: Box, nodes: list[Box], paths: list[tuple[Box, Sequence[Point]]], margin: float) -> bool:
    if any(spot.overlaps(n) for n in nodes):
        return False
    grown = spot.inflated(margin)
    return not any(grown.overlaps(hull) and polyline_hits(points, grown) for hull, points in paths)
