"""Why a renderer's image came out empty (one colour): the diagnosis behind BlankImageWarning.

A renderer says what its inputs should show (``Processor.shown_content()``, vgraph.shown_content). The
causes are checked in this order and the first that explains the empty image is named, with the
processor and the property to change; the causes after it are not blamed:

1. ``nothing_shown``: no element of any input shows. The value range when the volume is constant
   or every value lies beyond one end of its value range (the property that set the range is
   named: VolumeSource.value_range or its robust window); else the renderer's control: the
   transfer function (where it is opaque, where the values lie), the iso level (above every
   value) or the label table (hides every label held).
2. ``clipped_away``: the clip planes or the crop box (of the EntryExitPoints upstream) keep none of
   the shown elements: the plane that alone removes them all (``eep.clip_planes[0]``, what it
   keeps and where the shown elements lie), else the crop box, else the planes and box together.
3. ``slice_off_volume``: a slice's plane (a SliceViewer's ``last_plane``) misses the volume's
   cells: ``cursor`` (or ``normal``) is named.
4. ``out_of_view``: the kept shown elements lie outside the camera's view (behind the camera,
   nearer than its near plane, beyond its far plane, left, right, above or below the view) or
   cover less than a pixel: the camera that casts the rays is named (the EntryExitPoints' for a
   ray caster, the renderer's own otherwise).
5. ``masked_away``: what shows is kept and in view, but the ray caster's mask or cut-away
   (vgraph.masking) is on: they are named as the likely cause (they weigh samples, not voxels, so
   what they leave is not counted here).
6. ``unexplained``: what shows, is kept and is in view; the image is still empty.

Renderers of plug-ins that only say ``visible_content()`` (in words) get that said, as before.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import networkx as nx
import numpy as np

from vgraph.camera import Camera
from vgraph.shown_content import held_labels, transfer_function_alpha, unit_corners

AXES = "xyz"


@dataclass(frozen=True)
class Diagnosis:
    cause: str  # the function that named it: "nothing_shown", "clipped_away", ...
    text: str


class Case:
    """One renderer whose image is empty, with what it should show and what cuts and views it."""

    def __init__(self, network, renderer, shown: list, size: tuple[int, int]):
        self.network, self.renderer, self.shown, self.size = network, renderer, shown, size
        self.name = f"{renderer.id} ({renderer.type_name})"

    @cached_property
    def ancestors(self) -> list:
        """The processors upstream of the renderer, nearest first."""
        distance = nx.shortest_path_length(self.network.graph.reverse(copy=False), self.renderer.id)
        return [self.network.processors[pid] for pid in sorted(distance, key=distance.get)
                if pid != self.renderer.id]

    @cached_property
    def clipper(self):
        """The nearest processor upstream holding clip planes and a crop box (EntryExitPoints)."""
        return next((p for p in self.ancestors if "clip_planes" in p.properties), None)

    @cached_property
    def camera_holder(self):
        """The processor whose camera cast the rays: for a renderer fed entry points, the nearest
        one upstream with a camera; else the renderer itself."""
        fed = any(port.name == "entry" for port in self.renderer.inports)
        for processor in (self.ancestors if fed else [self.renderer]):
            if "camera" in processor.properties and isinstance(getattr(processor, "view_camera", None), Camera):
                return processor
        return None

    def cuts(self) -> tuple[tuple, tuple | None]:
        if self.clipper is None:
            return (), None
        return tuple(self.clipper.clip_planes), self.clipper.crop_box

    def presences(self) -> list:
        planes, crop = self.cuts()
        return [shown.presence(planes, crop) for shown in self.shown]

    @cached_property
    def content(self) -> str:
        """What shows, in words ("34% of the voxels are visible under the transfer function")."""
        several = len(self.shown) > 1
        return "; ".join(f"{s.port}: {share_text(s)}" if several else share_text(s)
                         for s in self.shown if s.share() > 0.0)

    @property
    def noun(self) -> str:
        return "tetrahedron" if self.shown[0].noun == "tetrahedra" else "voxel"


def diagnose(network, renderer, size: tuple[int, int]) -> Diagnosis | None:
    """Why ``renderer``'s image of ``size`` (width, height) is empty; None when it shows nothing
    it could say (it is no renderer, or has no input)."""
    shown = renderer.shown_content()
    if shown is None:
        return _said_in_words(renderer)
    if not shown:
        return None
    case = Case(network, renderer, shown, size)
    for cause in CAUSES:
        text = cause(case)
        if text:
            return Diagnosis(cause.__name__, text)
    return None


# --- 1. nothing shown: the value range or the renderer's control ----------------------------------
def nothing_shown(case: Case) -> str | None:
    if any(shown.share() > 0.0 for shown in case.shown):
        return None
    several = len(case.shown) > 1
    reasons = [(f"{s.port}: " if several else "") + hidden_because(case, s) for s in case.shown]
    return f"{case.name} rendered an empty image: " + "; ".join(reasons)


def hidden_because(case: Case, shown) -> str:
    """Why no element of one input shows."""
    rid, data = case.renderer.id, shown.data
    control = f"{rid}.{shown.control}"
    where = f"its {shown.port} ({data.source or 'in memory'})"
    if shown.rule == "labels":
        held = ", ".join(str(v) for v in held_labels(data).tolist()[:12])
        return (f"{control} hides every label {where} holds ({held}); show one of them (an entry with "
                f"opacity above 0, or unlisted: palette)")
    extremes = finite_extremes(data)
    if extremes is None and getattr(data, "bricks", None) is not None:  # a store not read whole
        return f"{control} shows none of the voxels of {where} (judged from the store's summary level)"
    if extremes is None:
        return f"{where} holds no finite value, so nothing can show"
    low, high = (float(v) for v in data.value_range)
    origin, fix = range_origin(case, shown)
    if extremes[0] == extremes[1]:
        value = float(extremes[0])
        return (f"{where} is constant, every finite {'value' if shown.noun == 'tetrahedra' else 'voxel'} "
                f"is {value:.7g} (intensity {float(data.normalized(value)):.3g} of its value range "
                f"[{low:.7g}, {high:.7g}], {origin}), and nothing is shown at that value; give the volume "
                f"a value range that places it where {control} shows it: {fix}")
    first, last = (float(v) for v in data.normalized(np.asarray(extremes, dtype=np.float64)))
    values = f"the values span {_n(extremes[0])} .. {_n(extremes[1])}"
    if first >= 1.0 or last <= 0.0:
        side, end = ("above", "top") if first >= 1.0 else ("below", "bottom")
        return (f"every value of {where} lies {side} its value range [{_n(low)}, {_n(high)}] ({origin}): "
                f"{values}, so each takes the {end} end of {control}, which shows nothing there; "
                f"{fix} to cover {_n(extremes[0])} .. {_n(extremes[1])}")
    held = (f"{where} holds intensities {_n(first)} .. {_n(last)} of its value range [{_n(low)}, "
            f"{_n(high)}] ({origin}; {values})")
    if shown.rule == "iso_level":
        level = getattr(case.renderer, shown.control)
        return (f"{control} {level:g} lies above every value: {held}; lower {control} below {_n(last)}")
    if shown.rule == "transfer_function":
        runs = opaque_runs(transfer_function_alpha(getattr(case.renderer, shown.control), data))
        if not runs:
            return f"{control} is transparent at every intensity (opacity 0 everywhere), so nothing of {where} shows"
        return (f"{control} gives opacity only to intensities {runs}, where no value lies: {held}; move its "
                f"opaque part onto {_n(max(first, 0.0))} .. {_n(min(last, 1.0))} or choose another preset")
    return f"{control} shows nothing of {where}: {held}"


def range_origin(case: Case, shown) -> tuple[str, str]:
    """(where the input's value range comes from, what to change): the VolumeSource (or
    MeshSource) upstream of the renderer's inport, followed through the processors between."""
    pid, port = case.renderer.id, shown.port
    for _ in range(len(case.network.processors)):
        connections = case.network.inputs_of(pid, port)
        if not connections:
            break
        source = case.network.processors[connections[0].source]
        if "value_range" in source.properties:
            prop = f"{source.id}.value_range"
            if source.property_values["value_range"] is not None:
                return f"set by {prop}", f"set {prop}"
            if source.property_values.get("window") == "robust":
                return (f"the robust window of {source.id}.window_percentiles",
                        f"set {prop} (or {source.id}.window to full)")
            return _range_of_data(shown.data), f"set {prop}"
        if not source.inports:
            break
        pid, port = source.id, source.inports[0].name
    return _range_of_data(shown.data), "set a value range (VolumeSource.value_range)"


def _range_of_data(data) -> str:
    return "the range the data declares" if data.declared_range is not None else "the data's own min .. max"


def opaque_runs(alpha: np.ndarray) -> str:
    """Where a LUT's opacity is above 0, as intensity intervals ("0.6 .. 1, 0.2 .. 0.3")."""
    opaque = np.concatenate([[False], alpha > 0.0, [False]])
    starts = np.flatnonzero(~opaque[:-1] & opaque[1:])
    ends = np.flatnonzero(opaque[:-1] & ~opaque[1:]) - 1
    last = len(alpha) - 1
    runs = [f"{_n(s / last)} .. {_n(e / last)}" for s, e in zip(starts, ends)]
    return ", ".join(runs[:4]) + (f" (and {len(runs) - 4} more)" if len(runs) > 4 else "")


# --- 2. clip planes and crop box ------------------------------------------------------------------
def clipped_away(case: Case) -> str | None:
    planes, crop = case.cuts()
    if not planes and crop is None:
        return None
    presences = [p for p in case.presences() if p.shown]
    if not presences or any(p.kept for p in presences):
        return None
    cid, shows = case.clipper.id, f"{case.noun} {case.renderer.id} shows"
    low = np.min([p.low for p in presences], axis=0)
    high = np.max([p.high for p in presences], axis=0)
    for index, plane in enumerate(planes):
        if all(p.reach[index][1] < 0.0 for p in presences):
            reach = (min(p.reach[index][0] for p in presences), max(p.reach[index][1] for p in presences))
            return (f"{case.name} rendered an empty image: {cid}.clip_planes[{index}] removes every {shows} "
                    f"(it keeps {kept_side(plane)}; they lie at {along(plane, reach, low, high)}); move "
                    f"it or turn its normal around")
    if crop is not None and not any(p.in_crop for p in presences):
        return (f"{case.name} rendered an empty image: {cid}.crop_box holds no {shows} (it keeps "
                f"{span(crop[:3], crop[3:])}; they lie at {span(low, high)}); widen it or clear it")
    cuts = f"{cid}.clip_planes" + (f" and {cid}.crop_box" if crop is not None else "")
    return (f"{case.name} rendered an empty image: {cuts} together keep no {shows}, though each "
            f"alone keeps some (they lie at {span(low, high)}); move one of them")


def kept_side(plane) -> str:
    """The half-space a plane keeps, as an inequality in world units ("x >= 300")."""
    normal, offset = plane.unit_normal(), plane.offset()
    axis = _axis_of(normal)
    if axis is not None:
        return f"{AXES[axis]} >= {_n(offset)}" if normal[axis] > 0 else f"{AXES[axis]} <= {_n(-offset)}"
    return f"{_linear(normal)} >= {_n(offset)}"


def along(plane, reach, low, high) -> str:
    """Where the shown elements lie along a plane's normal."""
    normal, offset = plane.unit_normal(), plane.offset()
    axis = _axis_of(normal)
    if axis is not None:
        return f"{AXES[axis]} {_n(low[axis])} .. {_n(high[axis])}"
    return f"{_linear(normal)} = {_n(reach[0] + offset)} .. {_n(reach[1] + offset)}"


# --- 3. a slice off the volume -------------------------------------------------------------------
def slice_off_volume(case: Case) -> str | None:
    plane = getattr(case.renderer, "last_plane", None)
    volume = case.shown[0].data
    if plane is None or not hasattr(volume, "voxel_to_world"):
        return None
    cells = volume.voxel_to_world(unit_corners() * np.asarray(volume.dims, dtype=np.float64) - 0.5)
    normal = np.asarray(plane.normal, dtype=np.float64)
    heights = (cells - np.asarray(plane.centre)) @ normal
    if heights.min() <= 0.0 <= heights.max():
        return None
    rid = case.renderer.id
    axis = _axis_of(normal)
    centre = np.asarray(plane.centre)
    if axis is not None:
        where = (f"lies at {AXES[axis]} = {_n(centre[axis])}, and the volume's cells span "
                 f"{AXES[axis]} {_n(cells[:, axis].min())} .. {_n(cells[:, axis].max())}")
    else:
        level = float(centre @ normal)
        where = (f"lies at {_linear(normal)} = {_n(level)}, and the volume's cells span "
                 f"{_n(level + heights.min())} .. {_n(level + heights.max())} along its normal")
    prop = f"{rid}.cursor" if getattr(case.renderer, "cursor", None) is not None else f"{rid}.normal"
    return (f"{case.name} rendered an empty image: its slice misses the volume: the plane {where}; "
            f"move {prop} into the volume (None: its centre)")


# --- 4. the camera --------------------------------------------------------------------------------
def out_of_view(case: Case) -> str | None:
    holder = case.camera_holder
    if holder is None:
        return None
    kept = [p for p in case.presences() if p.kept]
    if not kept:
        return None
    low = np.min([p.kept_low for p in kept], axis=0)
    high = np.max([p.kept_high for p in kept], axis=0)
    camera = holder.view_camera
    where = where_in_view(camera, low, high, case.size)
    if where is None:
        return None
    planes, crop = case.cuts()
    cut = " (those the clip planes and crop box keep)" if planes or crop is not None else ""
    return (f"{case.name} rendered an empty image although {case.content}: seen from {holder.id}.camera "
            f"(at {_point(camera.position)}, looking toward {_point(camera.focus)}) they{cut} lie {where}, "
            f"at {span(low, high)}; turn {holder.id}.camera toward them (fit_to_data frames the data; "
            f"vgraph run --view NAME too)")


def where_in_view(camera: Camera, low, high, size) -> str | None:
    """Where a world box lies outside a resolved camera's view, in words; None if it may be seen."""
    corners = np.asarray(low) + unit_corners() * (np.asarray(high) - np.asarray(low))
    homogeneous = np.c_[corners, np.ones(8)]
    eye = homogeneous @ camera.view_matrix().T
    near, far = camera.planes()
    if np.all(eye[:, 2] >= 0.0):  # the eye looks down -z
        return "behind the camera"
    clip = homogeneous @ camera.view_projection(size[0] / size[1]).T
    x, y, z, w = clip.T
    tests = ((f"nearer than its near plane (near = {_n(near)})", z < -w),
             (f"beyond its far plane (far = {_n(far)})", z > w),
             ("left of its view", x < -w), ("right of its view", x > w),
             ("below its view", y < -w), ("above its view", y > w))
    for words, outside in tests:
        if np.all(outside):
            return words
    if np.all(w > 0.0):
        ndc = clip[:, :2] / w[:, None]
        across = np.ptp(ndc, axis=0) / 2.0 * np.asarray(size, dtype=np.float64)
        if across.min() < 1.0:
            return f"in a speck of {_n(across[0])} x {_n(across[1])} pixels (under one pixel across)"
    return None


# --- 5. a mask or cut-away of the ray casters (vgraph.masking) -------------------------------------
def masked_away(case: Case) -> str | None:
    renderer = case.renderer
    removers = []
    if renderer.inputs.get("mask") is not None:
        labels = getattr(renderer, "mask_labels", "") or "every nonzero label"
        removers.append(f"{renderer.id}.mask ({getattr(renderer, 'mask_mode', 'keep')} {labels})")
    if getattr(renderer, "cutaway", "none") != "none":
        removers.append(f"{renderer.id}.cutaway ({renderer.cutaway} at {list(renderer.cutaway_center)}, "
                        f"size {list(renderer.cutaway_size)})")
    if not removers or not case.content:
        return None
    return (f"{case.name} rendered an empty image although {case.content}: "
            f"{' and '.join(removers)} removed every visible sample; check that the kept region holds them")


# --- 6. nothing to blame -------------------------------------------------------------------------
def unexplained(case: Case) -> str | None:
    if not case.content:
        return None
    holder = case.camera_holder
    seen = f", kept by the clip planes and in view of {holder.id}.camera" if holder is not None else ""
    return (f"{case.name} rendered an empty image although {case.content}{seen}: vgraph cannot name "
            f"the cause; check {case.renderer.id}'s other properties (opacities, sampling, window)")


CAUSES = (nothing_shown, clipped_away, slice_off_volume, out_of_view, masked_away, unexplained)


# --- renderers that say only in words ---------------------------------------------------------------
def _said_in_words(renderer) -> Diagnosis | None:
    content = renderer.visible_content()
    if content:
        return Diagnosis("unexplained", f"{renderer.id} ({renderer.type_name}) rendered an empty image "
                                        f"although {content}: is the volume in view (camera position, "
                                        f"near and far) and is its value range right?")
    return None


# --- words ----------------------------------------------------------------------------------------
def share_text(shown) -> str:
    share = shown.share()
    amount = f"{share:.0%}" if share >= 0.005 else "under 1%"
    return {"transfer_function": f"{amount} of the {shown.noun} are visible under the transfer function",
            "transfer_function_2d": f"{amount} of the voxels have values the 2D transfer function "
                                    f"shows at some gradient",
            "iso_level": f"{amount} of the voxels reach the iso level",
            "labels": f"{amount} of the voxels hold shown labels",
            "window": f"{amount} of the voxels are shown"}[shown.rule]


def finite_extremes(data):
    """(min, max) of the finite values of a volume or a mesh's scalars; None if none is finite."""
    extremes = getattr(data, "finite_extremes", None)
    if extremes is not None or not hasattr(data, "scalars"):
        return extremes
    finite = data.scalars[np.isfinite(data.scalars)]
    return (finite.min(), finite.max()) if finite.size else None


def span(low, high) -> str:
    return ", ".join(f"{a} {_n(lo)} .. {_n(hi)}" for a, lo, hi in zip(AXES, low, high))


def _axis_of(normal) -> int | None:
    axis = int(np.argmax(np.abs(normal)))
    return axis if abs(normal[axis]) > 1.0 - 1e-9 else None


def _linear(normal) -> str:
    terms = [f"{_n(c)} {a}" for c, a in zip(normal, AXES) if abs(c) > 1e-9]
    return " + ".join(terms).replace("+ -", "- ")


def _point(values) -> str:
    return "(" + ", ".join(_n(v) for v in values) + ")"


def _n(value) -> str:
    text = f"{float(value):.4g}"
    return "0" if text == "-0" else text
