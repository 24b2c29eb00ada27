"""The world box each view camera framed, for the canvas overlays (no Qt here: the render process
computes it, as it holds the data; the GUI process holds none).

``view_boxes(network)`` maps 'id.camera' (the keys of ``evaluator.view_cameras``) to the
(min, max) corners, (x, y, z) world units, of the data that processor drew: a volume's box spanned
by its voxel centres (``Volume.world_box``: for an oriented volume the axis-aligned box that holds
it), a mesh's bounds.
With the view camera of the same frame, the GUI projects the box's corners onto the canvas.
"""

from __future__ import annotations

from vgraph.camera import Camera
from vgraph.mesh import TetMesh
from vgraph.network import Network
from vgraph.volume import Volume

Box = tuple[tuple[float, float, float], tuple[float, float, float]]


def view_boxes(network: Network) -> dict[str, Box]:
    boxes = {}
    for processor_id, processor in network.processors.items():
        camera = getattr(processor, "view_camera", None)
        if not isinstance(camera, Camera) or "camera" not in processor.properties:
            continue
        box = _drawn_box(network, processor_id)
        if box is not None:
            boxes[f"{processor_id}.camera"] = box
    return boxes


def _drawn_box(network: Network, processor_id: str) -> Box | None:
    """The box of the first volume or mesh arriving at the processor (what its camera framed)."""
    for inport in network[processor_id].inports:
        for connection in network.inputs_of(processor_id, inport.name):
            data = network[connection.source].outputs.get(connection.outport)
            if isinstance(data, Volume):
                low, high = data.world_box()  # an oriented volume's turned box, held
            elif isinstance(data, TetMesh):
                low, high = data.box
            else:
                continue
            return tuple(float(v) for v in low), tuple(float(v) for v in high)
    return None
