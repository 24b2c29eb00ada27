"""What lies upstream of a canvas: the nearest processor, breadth-first over predecessors in
connection order, that answers a question (the camera the mouse turns, the clip planes a Ctrl-drag
moves, the SliceViewer whose image the canvas shows)."""

from __future__ import annotations

from collections import deque
from typing import Callable

# A canvas's message when no camera is upstream of it (here, not in canvas_view, so that the
# Qt-free slice_clicks, which the render process imports, can compare with it).
NO_CAMERA = "no camera upstream of this canvas"


def nearest_upstream(network, start: str, pick: Callable[[object, str], str | None],
                     include_start: bool = False) -> str | None:
    """The first answer ``pick(processor, processor_id)`` that is not None, nearest first; None if
    no processor upstream of ``start`` (nor ``start`` itself, with ``include_start``) answers."""
    if start not in network.graph:
        return None
    seen, queue = {start}, deque([start])
    while queue:
        processor_id = queue.popleft()
        if include_start or processor_id != start:
            answer = pick(network[processor_id], processor_id)
            if answer is not None:
                return answer
        for source in network.graph.predecessors(processor_id):
            if source not in seen:
                seen.add(source)
                queue.append(source)
    return None


def property_of_type(property_type: type) -> Callable[[object, str], str | None]:
    """A ``pick`` giving 'id.name' of a processor's first property of ``property_type``."""
    def pick(processor, processor_id: str) -> str | None:
        for name, prop in processor.properties.items():
            if isinstance(prop, property_type):
                return f"{processor_id}.{name}"
        return None
    return pick
