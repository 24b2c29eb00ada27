"""What the GUI evaluates after each change, and what a node shows (no Qt here).

``evaluate_view(network, scale, include_writers)`` runs in the render process (``render_process``),
which owns the OpenGL context; the GUI process only sends documents and shows what comes back.

Conventions:
- A processor is *ready* when its required inports are connected and everything upstream is ready;
  unready processors are not evaluated (they are not errors, only unfinished networks).
- The targets are the ready processors with no ready successor. A *display* (a sink with an image
  inport that writes no file: the Canvas) is rendered at its ``size`` times ``scale``, so the GUI
  can ask for cheap frames while the mouse moves; its image comes back as 8-bit RGBA, row 0 at the
  top.
- File writers (sinks with a ``file_path`` property) do not run on every edit; they run when asked
  (``include_writers=True``), as the CLI runs them.
- One failing processor does not stop the others: each target is evaluated on its own and targets
  downstream of a failure are skipped (the scheduler would only retry and fail again).
- Times are honest: the scheduler finishes the GL after each processor (``finish_each``), so a
  node's "evaluated in" holds its own GL work and the nodes' times add up to the frame. Measured
  on llvmpipe (the head ray caster at 128^2 and 512^2) the finishes cost nothing noticeable: the
  GL work is done before the frame is read back anyway (docs/guide/gui.md, "Timings").
"""

from __future__ import annotations

import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field

import networkx as nx
import numpy as np

from vgraph import derived
from vgraph.camera import Camera
from vgraph.errors import ProcessorError, VGraphWarning
from vgraph.frame_context import FrameContext
from vgraph.gl.raycasting.gradient_classification import editor_histogram
from vgraph.live.slice_clicks import slice_planes
from vgraph.image import Image
from vgraph.imagefile import to_uint8
from vgraph.mesh import TetMesh
from vgraph.network import Network
from vgraph.picking import depth_targets
from vgraph.processor import Processor
from vgraph.properties import (FilePathProperty, GradientOpacityProperty, Invalidation,
                               TransferFunction2DProperty, TransferFunctionProperty)
from vgraph.scheduler import blank_image_warning, evaluate
from vgraph.time_series import time_point_note
from vgraph.transfer_function import ValueScale
from vgraph.volume import Volume


def is_writer(processor_type: type[Processor]) -> bool:
    """A sink that writes a file: run on request, not on every edit."""
    return not processor_type.outports and any(
        isinstance(p, FilePathProperty) for p in processor_type.properties.values())


def is_display(processor_type: type[Processor]) -> bool:
    """A sink that shows an image (a Canvas): the GUI gives it a view."""
    return (not processor_type.outports and not is_writer(processor_type)
            and any(issubclass(port.data_type, Image) for port in processor_type.inports))


@dataclass
class EvaluationOutcome:
    ran: list[str] = field(default_factory=list)           # processors evaluated, in order
    failed: dict[str, str] = field(default_factory=dict)   # id -> reason
    not_ready: list[str] = field(default_factory=list)     # required inports unconnected upstream
    writers: list[str] = field(default_factory=list)       # writers left for an explicit run
    frames: dict[str, np.ndarray] = field(default_factory=dict)  # display id -> (H, W, 4) uint8
    blank: dict[str, str] = field(default_factory=dict)    # display id -> why its frame should not be empty
    warnings: list[str] = field(default_factory=list)      # VGraphWarnings of the processors that ran


def evaluate_view(network: Network, scale: float = 1.0, include_writers: bool = False,
                  draw=None, context: FrameContext | None = None, hovered=()) -> EvaluationOutcome:
    """``draw(display, size)``, if given, may return a display's picture drawn elsewhere (a
    cluster: ``vgraph.live.cluster``) instead of evaluating it here; None draws it here.
    ``context``: the frame context of every evaluation (the job's load limit). ``hovered``: the
    displays under the mouse, whose renderer's depth is drawn with the frame (in the same pass)
    for the hover readout's picks (vgraph.live.probes)."""
    outcome = EvaluationOutcome()
    not_ready, writers, targets = network.graph_query(("view", include_writers),
                                                      lambda: _view_plan(network, include_writers))
    outcome.not_ready, outcome.writers = list(not_ready), list(writers)
    for target, ancestors in targets:
        if not ancestors.isdisjoint(outcome.failed):
            continue
        display = is_display(type(network[target]))
        size = display_size(network[target], scale) if display else None
        try:
            with _collected_warnings(outcome.warnings):
                pixels = draw(target, size) if display and draw is not None else None
                if pixels is None:
                    also = depth_targets(network, target) if display and target in hovered else ()
                    report = evaluate(network, (target, *also), size, finish_each=True, context=context)
                    outcome.ran.extend(report.ids)
        except ProcessorError as error:
            outcome.ran.extend(network.last_evaluation.ids)
            outcome.failed[error.processor_id] = error.reason
            continue
        if display:
            pixels = network.output(target).to_numpy() if pixels is None else pixels
            outcome.frames[target] = to_uint8(pixels)
            warning = blank_image_warning(network, target, pixels)
            if warning:
                outcome.blank[target] = warning
    return outcome


def _view_plan(network: Network, include_writers: bool):
    """(not ready, writers left alone, (target, its ancestors) in evaluation order, displays
    last): what the graph says, asked once per graph shape (``Network.graph_query``)."""
    order = list(nx.topological_sort(network.graph))
    ready = ready_processors(network, order)
    writers = [pid for pid in ready if is_writer(type(network[pid])) and not include_writers]
    runnable = ready - set(writers)
    targets = [pid for pid in order if pid in runnable
               and not any(s in runnable for s in network.graph.successors(pid))]
    targets.sort(key=lambda pid: is_display(type(network[pid])))  # frames last
    return (tuple(pid for pid in order if pid not in ready), tuple(writers),
            tuple((pid, frozenset(nx.ancestors(network.graph, pid))) for pid in targets))


@contextmanager
def _collected_warnings(messages: list[str]):
    """Append the VGraphWarnings raised inside to ``messages`` (the GUI logs them); other
    warnings go where they would have gone."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", VGraphWarning)
        try:
            yield
        finally:
            for warning in caught:
                if issubclass(warning.category, VGraphWarning):
                    messages.append(str(warning.message))
                else:
                    warnings.showwarning(warning.message, warning.category, warning.filename, warning.lineno)


def ready_processors(network: Network, order: list[str]) -> set[str]:
    ready: set[str] = set()
    for pid in order:
        processor = network[pid]
        connected = all(inport.optional or network.inputs_of(pid, inport.name)
                        for inport in processor.inports)
        if connected and processor.awaiting() is None and all(u in ready for u in network.graph.predecessors(pid)):
            ready.add(pid)
    return ready


def display_size(processor: Processor, scale: float) -> tuple[int, int]:
    width, height = processor.property_values.get("size", (512, 512))
    return max(1, round(width * scale)), max(1, round(height * scale))


def histograms(network: Network) -> dict[str, np.ndarray]:
    """For each processor with a transfer function, the histogram (256 bins over the value range)
    of the data each TF classifies, under 'id.<TF property>' (classified_inputs), for that TF's
    editor; and under 'id' that of the processor's first connected volume (for scripts). Under
    'id.<2D TF property>' and 'id.<gradient-opacity property>', where that property is set, the
    (gradient, value) histogram of the processor's volume and its counts per gradient bin
    (vgraph.gl.raycasting.gradient_classification.editor_histogram)."""
    found = _measured(network, lambda data: data.histogram()[0])
    by_gradient = {TransferFunction2DProperty: lambda counts: counts,
                   GradientOpacityProperty: lambda counts: counts.sum(axis=1)}
    for processor in network.processors.values():
        volume = processor.inputs.get("volume")
        for name, prop in processor.properties.items():
            if (type(prop) in by_gradient and isinstance(volume, Volume)
                    and processor.property_values[name] is not None):
                counts = editor_histogram(volume)
                if counts is not None:
                    found[f"{processor.id}.{name}"] = by_gradient[type(prop)](counts)
    return found


def value_scales(network: Network) -> dict[str, ValueScale]:
    """Under the same keys: the ValueScale of that data (TFs in data units, percentiles)."""
    return _measured(network, ValueScale.of)


CLASSIFIED = (Volume, TetMesh)  # data a transfer function classifies: histogram, value range, percentiles


def _measured(network: Network, measure) -> dict:
    """``measure`` of each classified input by key, once per data object (several keys may share one)."""
    measured, by_data = {}, {}
    for key, data in classified_inputs(network):
        if id(data) not in by_data:
            by_data[id(data)] = measure(data)
        measured[key] = by_data[id(data)]
    return measured


def classified_inputs(network: Network):
    """(key, data) of what the transfer functions classify: 'id' -> the processor's first
    connected volume or mesh, and 'id.<TF property>' -> the data of the inport the processor pairs
    with that TF in its ``transfer_function_inports`` class attribute (the MultiVolumeRayCaster:
    transfer_function2 -> volume2), or the first one for a TF it does not pair (the RayCaster's
    single TF). A TF whose paired inport has no data gets no key: its editor shows no histogram."""
    for processor in network.processors.values():
        tfs = [name for name, p in processor.properties.items() if isinstance(p, TransferFunctionProperty)]
        if not tfs:
            continue
        arrived = {}  # inport -> data, in inport order
        for inport in processor.inports:
            sources = network.inputs_of(processor.id, inport.name) if issubclass(inport.data_type, CLASSIFIED) else []
            data = network[sources[0].source].outputs.get(sources[0].outport) if sources else None
            if isinstance(data, CLASSIFIED):
                arrived[inport.name] = data
        if not arrived:
            continue
        first = next(iter(arrived.values()))
        yield processor.id, first
        pairing = getattr(processor, "transfer_function_inports", {})
        for name in tfs:
            data = arrived.get(pairing[name]) if name in pairing else first
            if data is not None:
                yield f"{processor.id}.{name}", data


def view_cameras(network: Network) -> dict:
    """'id.camera' -> the concrete camera of the last frame, for processors that resolved one
    (a camera that fits the data or chooses its near/far needs it to zoom and pan from); and
    'id.slice_plane' -> a SliceViewer's plane, where a click in its canvas lands (live.slice_clicks)."""
    return {f"{pid}.camera": processor.view_camera for pid, processor in network.processors.items()
            if isinstance(getattr(processor, "view_camera", None), Camera) and "camera" in processor.properties
            } | slice_planes(network)


# --- what a node shows --------------------------------------------------------------------------
@dataclass(frozen=True)
class ProcessorStatus:
    state: str    # "evaluated", "error", "invalid", "not_ready", "writer"; "running" (GUI side)
    text: str     # one short line for the node
    detail: str   # the full story for a tooltip or the inspector
    # What the processor produced, for the inspector (the GUI process holds no volume): one
    # line per volume outport, and the size of the file a source read. Empty when not evaluated.
    data: str = ""
    seconds: float | None = None   # the last run's wall time, its GL work included
    fraction: float | None = None  # "running": how far its steps are (None: no steps known)
    in_use: tuple = ()  # (property, value) of its automatic properties in the last run (values_in_use)


def processor_status(network: Network, processor: Processor) -> ProcessorStatus:
    """What a node shows about its processor's evaluation."""
    if processor.last_error:
        return ProcessorStatus("error", "error", processor.last_error)
    if processor.invalid_level == Invalidation.VALID and processor.evaluation_count:
        seconds = processor.last_seconds or 0.0
        return ProcessorStatus("evaluated", f"evaluated in {format_seconds(seconds)}",
                               f"up to date; ran {processor.evaluation_count} time"
                               f"{'s' * (processor.evaluation_count != 1)}, the last run took "
                               f"{format_seconds(seconds)} (its GL work included)",
                               "\n".join(filter(None, (data_summary(processor), processor.frame_summary()))),
                               seconds, in_use=tuple(processor.values_in_use().items()))
    missing = [p.name for p in processor.inports
               if not p.optional and not network.inputs_of(processor.id, p.name)]
    if missing:
        return ProcessorStatus("not_ready", "inport not connected",
                               f"required inports not connected: {', '.join(missing)}")
    awaited = processor.awaiting()
    if awaited:
        return ProcessorStatus("not_ready", f"needs {awaited}",
                               f"choose {awaited} in the Properties panel (path) to run it")
    if is_writer(type(processor)):
        return ProcessorStatus("writer", "writes on request",
                               "writers run with Network > Run Writers, not on every edit")
    return ProcessorStatus("invalid", "not evaluated", "waiting for evaluation (or for its inputs)")


def data_summary(processor: Processor) -> str:
    """Dimensions, type, spacing and value range of each volume the processor output, the time
    point of a file with several (vgraph.time_series), and the size of the file a source read. A
    few hundred bytes: it crosses the process boundary on every evaluation. Kept per run of the
    processor: statuses are built for every frame of a drag, and a Zarr store's size is a walk over
    its chunk files (vgraph.derived)."""
    run = (processor.evaluation_count, tuple(id(data) for data in processor.outputs.values()))
    return derived.value(processor, "data summary", lambda: _summary(processor), params=run)


def _summary(processor: Processor) -> str:
    lines = []
    for name, data in processor.outputs.items():
        if isinstance(data, Volume):
            x, y, z = data.dims
            lo, hi = data.value_range
            lines.append(f"{name}: {x} \u00d7 {y} \u00d7 {z} {data.data.dtype}, spacing "
                         f"({', '.join(f'{s:g}' for s in data.spacing)}), values {lo:g} to {hi:g}")
    note = time_point_note(processor)  # "t = 0 of 12 time points; choose with source.time_step"
    if note and lines:
        lines.append(note)
    if processor.outports and lines:
        for prop in processor.properties.values():
            value = processor.property_values[prop.name]
            if isinstance(prop, FilePathProperty) and value:
                size = _file_size(processor.resolve_path(value))
                if size is not None:
                    lines.append(f"file: {format_bytes(size)}")
    return "\n".join(lines)


HEADER_SUFFIXES = (".mhd", ".nhdr", ".hdr")


def _file_size(path) -> int | None:
    """Bytes of a file, or of all files under a folder (a Zarr store, a DICOM series); a header
    (.mhd, .nhdr, .hdr) counts with its data file of the same name, which holds nearly all."""
    try:
        if path.is_dir():
            return sum(f.stat().st_size for f in path.rglob("*") if f.is_file())
        if path.suffix.lower() in HEADER_SUFFIXES:
            return sum(f.stat().st_size for f in path.parent.glob(path.stem + ".*") if f.is_file())
        return path.stat().st_size
    except OSError:
        return None


def format_bytes(size: int) -> str:
    for unit in ("bytes", "KiB", "MiB", "GiB"):
        if size < 1024 or unit == "GiB":
            return f"{size} {unit}" if unit == "bytes" else f"{size:.1f} {unit}"
        size /= 1024


def running_status(progress) -> ProcessorStatus:
    """What a node shows while its processor runs (``progress``: a ``vgraph.progress.Progress``)."""
    fraction = progress.fraction
    step = progress.what or "running"
    text = f"{step} {fraction * 100:.0f}%" if fraction is not None else f"{step}..."
    return ProcessorStatus("running", text, f"running now: {progress.describe()}", fraction=fraction)


def waiting_status(upstream: str) -> ProcessorStatus:
    """What a node downstream of the running processor ``upstream`` shows: it runs after it."""
    return ProcessorStatus("invalid", f"waiting for {upstream}",
                           f"runs again once {upstream} (running now) is done")


def format_seconds(seconds: float) -> str:
    return f"{seconds * 1000:.1f} ms" if seconds < 1 else f"{seconds:.2f} s"
