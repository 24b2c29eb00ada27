"""Picking: what lies under a pixel of a canvas (``Network.pick(canvas, x, y)``; issue 36).

Coordinates: ``x, y`` are the canvas image's pixel column and row (its ``size``; row 0 at the
top), fractions allowed, an integer being the pixel's centre (as ``SlicePlane.pixel_to_world``):
the image covers -0.5 <= x < width - 0.5 and likewise y. Anything else, or a canvas id that is not
a Canvas, or a canvas with no renderer that says where its pixels lie, is a ``PickError``.

Where the point comes from, by the renderer nearest upstream of the canvas:
- A SliceViewer: the exact point of its plane under (x, y) (``SlicePlane.pixel_to_world``).
- A renderer with a ``depth`` output (RayCaster, MultiVolumeRayCaster, ProjectedTetrahedra,
  GeometryRenderer ...; several behind an ImageCompositor: each is picked and the nearest hit
  along the view wins): its depth image (the ray casters' convention: g = distance in world units
  from the ray's start on the near plane, a = 1 where something was drawn), read at the pixel and
  put on that pixel's ray of the renderer's camera of the frame (``view_camera``; the ray through
  the pixel centre, ``Camera.tile(...).rays``). The depth output is drawn on demand: the first
  pick of a frame draws it (once), later picks of the same frame read it.
- In iso mode (``compositing == "iso"``, or a surface renderer with an ``iso_level`` and no
  compositing: the CurvatureRaycaster) the point is refined on the tricubic B-spline surface
  (vgraph.picking_surface): ``surface`` has it, with normal and curvatures.
A pixel where nothing was drawn is a result with ``hit`` False and ``reason`` saying so.

At the point: the voxel index (i, j, k) of the renderer's (first) volume, nearest voxel centre,
the value of a tetrahedral mesh the renderer draws, interpolated in the tetrahedron holding the
point (vgraph.picking_mesh), and the value of every volume upstream of the renderer (``samples``): trilinear for volumes of
samples (as the ray casters' default interpolation), for label volumes the LabelRayCaster's
majority rule over the 8 voxels around it (with the label's name from a label table that draws
it, else "label N"), the tricubic spline for B-spline
coefficients. A point outside a volume's box gives that volume no value (``value`` None).
Volumes drawn brick by brick (OME-Zarr stores) are sampled at their full-resolution level, the
8 voxels around the point read alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import networkx as nx
import numpy as np
from scipy.ndimage import map_coordinates

from vgraph.errors import VGraphError
from vgraph.image import Image
from vgraph.labels import BACKGROUND, LabelTable, majority
from vgraph.mesh import TetMesh
from vgraph.picking_mesh import mesh_value
from vgraph.picking_surface import SurfacePoint, refine_on_surface, spline_value
from vgraph.volume import Volume


class PickError(VGraphError):
    """A pick that cannot be answered: not a canvas, a pixel outside it, no renderer upstream."""


@dataclass(frozen=True)
class VolumeSample:
    """One upstream volume's value at the picked point."""
    source: str                      # 'processor.outport' of the volume
    value: float | None              # None outside its box (or not sampled: ``note``)
    voxel: tuple[int, int, int] | None  # nearest voxel (i, j, k), None outside
    label: str | None = None         # label volumes: the label's name
    note: str = ""


@dataclass(frozen=True)
class PickResult:
    """What lies under one pixel of a canvas."""
    canvas: str
    x: float
    y: float
    kind: str                        # "slice" or "3d"
    renderer: str                    # the processor whose pixels were picked
    hit: bool                        # False: nothing drawn there (``reason``)
    point: tuple[float, float, float] | None = None   # world (patient) coordinates
    voxel: tuple[int, int, int] | None = None         # of the renderer's (first) volume
    samples: tuple[VolumeSample, ...] = ()
    surface: SurfacePoint | None = None               # iso mode: the tricubic surface point
    reason: str = ""
    eye_distance: float = math.inf   # 3D: the point's depth in front of the camera (the nearest renderer wins)

    @property
    def value(self) -> float | None:
        """The first volume's value (the renderer's own), or None."""
        return self.samples[0].value if self.samples else None


def pick(network, canvas_id: str, x: float, y: float, size: tuple[int, int] | None = None,
         context=None) -> PickResult:
    """What lies under pixel (x, y) of canvas ``canvas_id`` (module docstring). ``size``: the
    frame (width, height) the pixel refers to, when it is not the canvas's ``size`` (the GUI's
    frames drawn at a resolution scale); the network is evaluated at it, with ``context`` (the
    FrameContext the frame was drawn with: another one would draw the frame again)."""
    own_size = _canvas_size(network, canvas_id)
    size = own_size if size is None else (int(size[0]), int(size[1]))
    _check_pixel(canvas_id, x, y, size)
    network.update(canvas_id, size=size, context=context)
    renderers = _renderers(network, canvas_id)
    if hasattr(network[renderers[0]], "last_plane"):
        return _pick_slice(network, canvas_id, renderers[0], float(x), float(y), size)
    renderers = [r for r in renderers if not hasattr(network[r], "last_plane")]
    network.update(*(f"{r}.depth" for r in renderers), size=size, context=context)
    results = [_pick_3d(network, canvas_id, r, float(x), float(y), size) for r in renderers]
    hits = [result for result in results if result.hit]
    return min(hits, key=lambda result: result.eye_distance) if hits else results[0]


def _canvas_size(network, canvas_id: str) -> tuple[int, int]:
    if canvas_id not in network.processors:
        raise PickError(f"pick: no processor '{canvas_id}' in the network")
    if not _is_canvas(network[canvas_id]):
        raise PickError(f"pick: '{canvas_id}' is a {type(network[canvas_id]).__name__}, not a canvas")
    width, height = network[canvas_id].property_values["size"]
    return int(width), int(height)


def _is_canvas(processor) -> bool:
    """A sink that shows an image at its ``size`` (the Canvas; vgraph.live.evaluator.is_display)."""
    return (not processor.outports and "size" in processor.properties
            and any(issubclass(port.data_type, Image) for port in processor.inports))


def _check_pixel(canvas_id: str, x, y, size) -> None:
    width, height = size
    try:
        fx, fy = float(x), float(y)
    except (TypeError, ValueError):
        raise PickError(f"pick: canvas '{canvas_id}': the pixel must be two numbers, got {x!r}, {y!r}") from None
    if not (math.isfinite(fx) and math.isfinite(fy) and -0.5 <= fx < width - 0.5 and -0.5 <= fy < height - 0.5):
        raise PickError(f"pick: canvas '{canvas_id}': pixel ({x}, {y}) is outside its "
                        f"{width}x{height} image")


def _places_pixels(processor) -> bool:
    return hasattr(processor, "last_plane") or any(port.name == "depth" for port in processor.outports)


def _renderers(network, canvas_id: str) -> list[str]:
    """The processors upstream of the canvas that place its pixels in the world, nearest first:
    on each path from the canvas the first such one (several behind an ImageCompositor; a
    GeometryRenderer that only feeds a ray caster's entry points is not one)."""
    found, seen, frontier = [], {canvas_id}, [canvas_id]
    while frontier:
        following = []
        for processor_id in frontier:
            for source in network.graph.predecessors(processor_id):
                if source in seen:
                    continue
                seen.add(source)
                (found if _places_pixels(network[source]) else following).append(source)
        frontier = following
    if not found:
        raise PickError(f"pick: canvas '{canvas_id}': no renderer upstream writes depth or a slice "
                        f"plane, so its pixels have no place in the world")
    return found


def depth_targets(network, canvas_id: str) -> tuple[str, ...]:
    """'renderer.depth' of the 3D renderers whose pixels a pick of the canvas reads (none for a
    slice view, or when nothing upstream places pixels): drawn with the frame, later picks of that
    frame only read them."""
    try:
        renderers = _renderers(network, canvas_id)
    except PickError:
        return ()
    return tuple(f"{r}.depth" for r in renderers if not hasattr(network[r], "last_plane"))


# --- slices ---------------------------------------------------------------------------------------
def _pick_slice(network, canvas_id, viewer_id, x, y, size) -> PickResult:
    plane = network[viewer_id].last_plane
    point = plane.pixel_to_world(x, y, size)
    return _result_at(network, canvas_id, viewer_id, x, y, "slice", point)


# --- 3D views -------------------------------------------------------------------------------------
def _pick_3d(network, canvas_id, renderer_id, x, y, size) -> PickResult:
    renderer = network[renderer_id]
    depth = network.output(f"{renderer_id}.depth")
    width, height = depth.size
    column = min(width - 1, max(0, int(math.floor((x + 0.5) * width / size[0]))))
    row = min(height - 1, max(0, int(math.floor((y + 0.5) * height / size[1]))))
    distance, covered = _depth_at(depth, column, row)
    if not covered:
        return PickResult(canvas_id, x, y, "3d", renderer_id, hit=False,
                          reason=f"nothing drawn at pixel ({column}, {row}) of {renderer_id}")
    camera = getattr(renderer, "view_camera", None)
    if camera is None:
        raise PickError(f"pick: canvas '{canvas_id}': {renderer_id} reported no camera for its frame")
    origins, directions = camera.tile(column, row, 1, 1, width, height).rays(1, 1)
    origin, direction = origins[0, 0], directions[0, 0]
    point = origin + distance * direction
    surface = _iso_surface(network, renderer, origin, direction, distance)
    result = _result_at(network, canvas_id, renderer_id, x, y, "3d", point, surface)
    depth = (point - np.asarray(camera.position)) @ camera.basis()[2]  # each renderer has its own near plane
    return replace(result, eye_distance=float(depth))


def _depth_at(depth, column: int, row: int) -> tuple[float, bool]:
    """(distance g, drawn) of one pixel of a depth image, read alone (not the whole image)."""
    width, height = depth.size
    raw = depth.framebuffer.read(viewport=(column, height - 1 - row, 1, 1), components=4, dtype="f4")
    _, distance, _, alpha = np.frombuffer(raw, dtype=np.float32)
    return float(distance), bool(alpha > 0.0)


def _iso_surface(network, renderer, origin, direction, distance) -> SurfacePoint | None:
    values = renderer.property_values
    surface_mode = values.get("compositing", "iso") == "iso"  # no compositing: a surface renderer
    if "iso_level" not in values or not surface_mode:
        return None
    volume = _own_volumes(network, renderer.id)
    if not volume:
        return None
    volume = volume[0]
    if volume.bricks is not None and not volume.fits_budget:
        return None  # the spline needs the whole array; a store beyond its memory budget has none
    low, high = volume.value_range
    level = low + float(values["iso_level"]) * (high - low)
    return refine_on_surface(volume, level, origin, direction, distance)


# --- values at the point --------------------------------------------------------------------------
def _result_at(network, canvas_id, renderer_id, x, y, kind, point, surface=None) -> PickResult:
    where = np.asarray(surface.point if surface is not None else point, dtype=float)
    samples = _mesh_samples(network, renderer_id, where) + tuple(
        _sample(network, source, volume, where) for source, volume in _upstream_volumes(network, renderer_id))
    own = _own_volumes(network, renderer_id)
    voxel = _nearest_voxel(own[0], where) if own else None
    return PickResult(canvas_id, x, y, kind, renderer_id, hit=True,
                      point=tuple(float(v) for v in np.asarray(point, float)), voxel=voxel,
                      samples=samples, surface=surface)


def _mesh_samples(network, renderer_id: str, point) -> tuple[VolumeSample, ...]:
    """The renderer's tetrahedral meshes at the point, interpolated in the tetrahedron holding it."""
    samples = []
    for inport, data in network[renderer_id].inputs.items():
        if not isinstance(data, TetMesh):
            continue
        connection = network.inputs_of(renderer_id, inport)[0]
        source = f"{connection.source}.{connection.outport}"
        found = mesh_value(data, point)
        samples.append(VolumeSample(source, None, None, note="outside the mesh") if found is None else
                       VolumeSample(source, found.value, None, note=f"in tetrahedron {found.cell}"))
    return tuple(samples)


def _own_volumes(network, processor_id: str) -> list[Volume]:
    """The volumes the processor received, in inport order."""
    return [data for data in network[processor_id].inputs.values() if isinstance(data, Volume)]


def _upstream_volumes(network, renderer_id: str) -> list[tuple[str, Volume]]:
    """('id.outport', volume) of every volume upstream of the renderer: its own inputs' first,
    then the others nearest first; each volume once."""
    ancestors = nx.ancestors(network.graph, renderer_id)
    nearest_first = [pid for pid in reversed(list(nx.topological_sort(network.graph))) if pid in ancestors]
    found, seen = [], set()
    own = {id(v) for v in _own_volumes(network, renderer_id)}
    for pid in nearest_first:
        for outport, data in network[pid].outputs.items():
            if isinstance(data, Volume) and id(data) not in seen:
                seen.add(id(data))
                found.append((f"{pid}.{outport}", data))
    found.sort(key=lambda item: id(item[1]) not in own)  # stable: the renderer's own first
    return found


def _nearest_voxel(volume: Volume, point) -> tuple[int, int, int] | None:
    index = np.rint(volume.world_to_voxel(point)).astype(np.int64)
    if np.any(index < 0) or np.any(index >= np.array(volume.dims)):
        return None
    return tuple(int(v) for v in index)


def _sample(network, source: str, volume: Volume, point) -> VolumeSample:
    voxel = _nearest_voxel(volume, point)
    if voxel is None:
        return VolumeSample(source, None, None, note="outside the volume")
    block, offset = _block_around(volume, point)
    table = _label_table(network, source)
    if table is not None or volume.holds_labels:
        value = _label_at(block, offset, table or LabelTable.default())
        return VolumeSample(source, float(value), voxel, label=_label_name(table, value))
    if volume.is_spline_coefficients:
        return VolumeSample(source, float(spline_value(volume, point)), voxel, note="cubic B-spline")
    value = map_coordinates(block, offset[::-1].reshape(3, 1), order=1, mode="nearest")[0]
    return VolumeSample(source, float(value), voxel)


def _block_around(volume: Volume, point) -> tuple[np.ndarray, np.ndarray]:
    """The (up to) 2 x 2 x 2 voxels [z, y, x] around the point (clamped onto the voxel centres'
    box, as clamp-to-edge filtering) and the point's index offset (x, y, z) in them. A volume
    drawn brick by brick gives them from its full-resolution level (only those voxels are read)."""
    dims = np.array(volume.dims)
    index = np.clip(volume.world_to_voxel(point), 0, dims - 1)
    low = np.clip(np.floor(index), 0, np.maximum(dims - 2, 0)).astype(np.int64)
    high = np.minimum(low + 2, dims)
    if volume.bricks is not None:
        block = volume.bricks.read(0, tuple(int(v) for v in low[::-1]), tuple(int(v) for v in high[::-1]))
    else:
        block = volume.data[low[2]:high[2], low[1]:high[1], low[0]:high[0]]
    return np.asarray(block), index - low


def _label_at(block: np.ndarray, offset, table: LabelTable) -> int:
    """The label at the point by the LabelRayCaster's majority rule (vgraph.labels.majority) over
    the voxels around it (``_block_around``), so a pick on a label's surface names that label even
    where the nearest voxel is outside it; where no shown label wins, the nearest voxel's label."""
    labels = block.astype(np.int64)
    shown = table.colors(labels.ravel())[:, 3].reshape(labels.shape) > 0.0
    classes = np.where(shown, labels, BACKGROUND)
    texture = (np.asarray(offset) + 0.5) / np.array(labels.shape[::-1])  # the point in the block's [0, 1]^3
    winner = int(majority(classes, texture[None, :])[0][0])
    if winner != BACKGROUND:
        return winner
    nearest = np.clip(np.rint(offset).astype(np.int64), 0, np.array(labels.shape[::-1]) - 1)
    return int(labels[nearest[2], nearest[1], nearest[0]])


def _label_table(network, source: str) -> LabelTable | None:
    """The label table of a processor fed from ``source`` ('id.outport'; a LabelRayCaster's), or None."""
    for connection in network.connections:
        if f"{connection.source}.{connection.outport}" != source:
            continue
        for value in network[connection.target].property_values.values():
            if isinstance(value, LabelTable):
                return value
    return None


def _label_name(table: LabelTable | None, value: int) -> str:
    if table is not None:
        for entry in table.labels:
            if entry.value == value and entry.name:
                return entry.name
    return f"label {value}"
