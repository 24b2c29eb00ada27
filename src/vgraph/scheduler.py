"""Demand-driven evaluation.

``evaluate(network, targets, size)`` runs, in topological order, only the processors the targets
depend on, and of those only the invalid ones. Processors outside the targets' ancestors are never
initialised, so they compile no shader and upload no texture. Every evaluation is recorded (which
processors ran, in order, and how long each took; on a failure also the processor that failed, its
time and its error). A failure inside a processor becomes a ProcessorError naming its id and type;
the processor stays invalid and the network usable.

Times: GL calls return before the GL has done the work, which lands on whoever waits for it first
(a readback downstream, the next upload). With ``finish_each`` (``vgraph run --profile``, the
GUI) the scheduler waits for the GL after each processor (``ctx.finish()``), so each record holds
the processor's own GL work and the records add up to the evaluation's wall time. Without it the
records say how long each ``process()`` call took, and the GL work of a processor may be counted
with a later one or with none (docs/reference/general/cli.md, ``--profile``). Each processor's start is announced to
``vgraph.progress`` listeners (the GUI shows which processor runs).

The frame context (``context=FrameContext(...)``, vgraph.frame_context) goes to the processors that
declare fields of it in ``uses_context``, narrowed to those fields, as ``process(..., context=)``;
one whose fields differ from its last evaluation runs again, with what is downstream.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import networkx as nx
import numpy as np

from vgraph import progress
from vgraph.errors import ProcessorError, VGraphError, VGraphWarning
from vgraph.frame_context import NO_CONTEXT, FrameContext
from vgraph.gl_context import collect_garbage, get_context, has_context
from vgraph.memory import out_of_memory
from vgraph.network import Network, split_address
from vgraph.processor import Processor
from vgraph.properties import Invalidation

DEFAULT_SIZE = (512, 512)


@dataclass
class EvaluationRecord:
    id: str
    type: str
    seconds: float


@dataclass
class FailureRecord(EvaluationRecord):
    error: str  # the ProcessorError's reason, e.g. "ZeroDivisionError: division by zero"


@dataclass
class EvaluationReport:
    evaluated: list[EvaluationRecord] = field(default_factory=list)  # finished, in order
    total_seconds: float = 0.0
    failed: FailureRecord | None = None  # the processor whose failure ended the evaluation
    gl_finished: bool = False  # each record includes its processor's GL work (``finish_each``)

    @property
    def ids(self) -> list[str]:
        """The processors that finished, in order (not the one that failed)."""
        return [record.id for record in self.evaluated]

    def to_json(self) -> dict:
        """``{"evaluated": [{"id", "type", "seconds"}], "failed": null or {"id", "type",
        "seconds", "error"}, "total_seconds", "gl_finished"}`` (what ``vgraph run --profile``
        writes)."""
        return {"evaluated": [vars(r) for r in self.evaluated],
                "failed": vars(self.failed) if self.failed else None,
                "total_seconds": self.total_seconds, "gl_finished": self.gl_finished}


def evaluate(network: Network, targets=(), size: tuple[int, int] | None = None,
             finish_each: bool = False, context: FrameContext | None = None) -> EvaluationReport:
    """Run what ``targets`` need (module docstring); ``finish_each``: wait for the GL after each
    processor, so that its record holds its GL work; ``context``: the frame's context (None: no
    field given)."""
    targets = list(targets) or [p.id for p in network.sinks()]
    target_ids = [_target_processor(network, t) for t in targets]
    size = _checked_size(size) if size is not None else default_size(network, target_ids)
    context = _checked_context(context)
    _, order, read = network.graph_query(("plan", tuple(targets), tuple(target_ids)),
                                         lambda: _plan(network, targets, target_ids))
    for pid in order:
        processor = network.processors[pid]
        if processor.renders_at_size and processor.render_size != size:
            processor.render_size = size
            network.invalidate_downstream(pid)
        if processor.uses_context and not _same_context(processor, context):
            network.invalidate_downstream(pid)  # the frame asks something else of it than last time
    _mark_wanted_outputs(network, read)

    report = EvaluationReport(gl_finished=finish_each)
    network.last_evaluation = report
    start = time.perf_counter()
    try:
        for pid in order:
            processor = network.processors[pid]
            if processor.invalid_level != Invalidation.VALID:
                try:
                    report.evaluated.append(_run(network, processor, finish_each, context))
                except ProcessorError as error:
                    report.failed = FailureRecord(pid, processor.type_name, processor.last_seconds or 0.0,
                                                  error.reason)
                    raise
    finally:
        report.total_seconds = time.perf_counter() - start
        collect_garbage()  # outputs replaced in this evaluation free their GL memory now
    return report


def _plan(network: Network, targets: list[str], target_ids: list[str]):
    """(the processors the targets need, their order, the outports read of each): the graph's
    answer, the same every frame until the graph changes (``Network.graph_query``)."""
    needed = frozenset(target_ids).union(*(nx.ancestors(network.graph, t) for t in target_ids))
    order = tuple(nx.topological_sort(network.graph.subgraph(needed)))
    read: dict[str, set[str]] = {pid: set() for pid in needed}
    for target in targets:
        if "." in target:
            processor_id, port = split_address(target)
            read[processor_id].add(port)
    for connection in network.connections:
        if connection.source in needed and connection.target in needed:
            read[connection.source].add(connection.outport)
    return needed, order, tuple((pid, frozenset(ports)) for pid, ports in read.items())


def _mark_wanted_outputs(network: Network, read) -> None:
    """Tell each needed processor which of its on-demand outports are read this evaluation (by a
    target or by a needed processor: ``read``, pairs of an id and its ports read); one that
    computed fewer of them last time runs again."""
    for pid, ports in read:
        processor = network.processors[pid]
        wanted = frozenset(p.name for p in processor.outports if p.on_demand and p.name in ports)
        if wanted <= processor.wanted and processor.invalid_level == Invalidation.VALID:
            continue  # its outputs hold what is read (and perhaps more): nothing to redo
        if not wanted <= processor.wanted:
            processor.invalidate()  # its other outputs come out the same: readers need not rerun
        processor.wanted = wanted


def _run(network: Network, processor: Processor, finish: bool = False,
         context: FrameContext = NO_CONTEXT) -> EvaluationRecord:
    start = time.perf_counter()
    used = context.narrowed(processor.uses_context) if processor.uses_context else None
    try:
        with progress.running(processor.id, processor.type_name):
            inputs = _gather_inputs(network, processor)
            if not processor.initialized:
                processor.initialize()
                processor.initialized = True
            extra = {"context": used} if used is not None else {}
            outputs = _checked_outputs(processor, processor.process(**inputs, **extra))
            if finish:
                finish_gl()
    except Exception as error:
        processor.last_error = _reason(error)
        processor.last_seconds = time.perf_counter() - start
        network.processor_evaluated(processor)
        # Out of memory is the input being too large for the machine as it is set up, not a bug
        raise ProcessorError(processor.id, processor.type_name, processor.last_error,
                             internal=not isinstance(error, (VGraphError, MemoryError))) from error
    processor.inputs, processor.outputs = inputs, outputs
    processor.evaluated_context = used
    processor.invalid_level = Invalidation.VALID
    processor.last_error = None
    processor.last_seconds = time.perf_counter() - start
    processor.evaluation_count += 1
    network.processor_evaluated(processor)
    return EvaluationRecord(processor.id, processor.type_name, processor.last_seconds)


def finish_gl() -> None:
    """Wait until the GL has done what was issued so far (nothing to wait for, and no context
    created, when no processor has used the GL)."""
    if has_context():
        get_context().finish()


def _reason(error: Exception) -> str:
    if isinstance(error, MemoryError):
        return str(out_of_memory(error))
    return str(error) if isinstance(error, VGraphError) else f"{type(error).__name__}: {error}"


def _gather_inputs(network: Network, processor: Processor) -> dict:
    inputs = {}
    for inport in processor.inports:
        data = [network.processors[c.source].outputs.get(c.outport)
                for c in network.inputs_of(processor.id, inport.name)]
        if not data and not inport.optional:
            raise VGraphError(f"inport '{inport.name}' ({inport.type_name}) is not connected")
        inputs[inport.name] = data if inport.multiple else (data[0] if data else None)
    return inputs


def _checked_outputs(processor: Processor, result) -> dict:
    if not processor.outports:
        return {}
    if len(processor.outports) == 1 and not isinstance(result, dict):
        result = {processor.outports[0].name: result}
    if not isinstance(result, dict):
        raise VGraphError(f"process() must return a dict of outputs by outport name, got {type(result).__name__}")
    for outport in processor.outports:
        data = result.get(outport.name)
        if data is not None and not isinstance(data, outport.data_type):
            raise VGraphError(f"process() returned {type(data).__name__} for outport "
                              f"'{outport.name}', which carries {outport.type_name}")
    unknown = set(result) - {p.name for p in processor.outports}
    if unknown:
        raise VGraphError(f"process() returned outputs for unknown outports {sorted(unknown)}")
    return result


# --- targets --------------------------------------------------------------------------------------
def _target_processor(network: Network, target: str) -> str:
    if "." not in target:
        network[target]  # raises with the list of ids
        return target
    processor_id, port = split_address(target)
    processor = network[processor_id]
    if processor.outport(port) is None:
        names = ", ".join(p.name for p in processor.outports) or "none"
        raise VGraphError(f"{processor_id} ({processor.type_name}) has no outport '{port}' (outports: {names})")
    return processor_id


def target_type(network: Network, target: str) -> type | None:
    """The data type ``target`` carries, as its port declares it (an outport's, or the one inport
    of a sink), known before evaluating; None when the sink has no single, single-connection inport."""
    processor = network[_target_processor(network, target)]
    if "." in target:
        return processor.outport(split_address(target)[1]).data_type
    inports = processor.inports
    return inports[0].data_type if len(inports) == 1 and not inports[0].multiple else None


def target_data(network: Network, target: str):
    if "." in target:
        processor_id, port = split_address(target)
        return network[processor_id].outputs.get(port)
    sink = network[target]
    if getattr(sink, "shown", None) is not None:
        return sink.shown  # a sink that shows something else than it received (the Canvas, resampled)
    if len(sink.inports) != 1:
        raise VGraphError(f"'{target}' is not a sink with one inport; name a port as ID.PORT")
    return sink.inputs.get(sink.inports[0].name)


def default_target(network: Network) -> str:
    """The network's canvas: the first Canvas, else the only sink."""
    canvases = [p.id for p in network.processors.values() if p.type_name == "Canvas"]
    sinks = [p.id for p in network.sinks()]
    if canvases:
        return canvases[0]
    if len(sinks) == 1:
        return sinks[0]
    raise VGraphError("the network has no Canvas; choose a port as ID.PORT "
                      f"(processors: {', '.join(network.processors) or 'none'})")


def default_size(network: Network, target_ids: list[str]) -> tuple[int, int]:
    """The size property of the first targeted sink that has one (a Canvas), else 512 x 512."""
    for pid in target_ids:
        processor = network.processors[pid]
        if "size" in processor.properties and not processor.outports:
            return tuple(processor.property_values["size"])
    return DEFAULT_SIZE


def _same_context(processor: Processor, context: FrameContext) -> bool:
    """Whether the fields ``processor`` uses hold what they held for its last process()."""
    return context.narrowed(processor.uses_context).same_as(processor.evaluated_context)


def _checked_context(context) -> FrameContext:
    if context is None:
        return NO_CONTEXT
    if not isinstance(context, FrameContext):
        raise VGraphError(f"context must be a vgraph.frame_context.FrameContext, got {type(context).__name__}")
    return context


def _checked_size(size) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in size)
    except (TypeError, ValueError):
        raise VGraphError(f"image size must be two integers (width, height), got {size!r}") from None
    if not (1 <= width <= 16384 and 1 <= height <= 16384):
        raise VGraphError(f"image size must be between 1 and 16384 per side, got {width}x{height}")
    return width, height


class BlankImageWarning(VGraphWarning):
    """A renderer produced a uniform image although its inputs have something visible."""


def blank_image_warning(network: Network, target: str, pixels: np.ndarray) -> str | None:
    """A warning when ``pixels`` (the colour image at ``target``: an ``image`` outport or a sink)
    are all one colour although a renderer it comes from had something to show, naming the cause
    (vgraph.blank_causes: the value range, the transfer function, clip planes or crop box, a slice
    off the volume, the camera); None otherwise. Of several renderers upstream, the nearest whose
    inputs show something is diagnosed, else the nearest that shows nothing."""
    if pixels.ndim != 3 or pixels.size == 0:
        return None
    # every 7th pixel of every 7th row first: an image with something in it (nearly every frame)
    # differs there already, at a 49th of the whole comparison's cost (0.5 ms a 256^2 frame)
    if not np.all(pixels[::7, ::7] == pixels[:1, :1]) or not np.all(pixels == pixels[:1, :1]):
        return None
    if "." in target and split_address(target)[1] != "image":
        return None  # depth, positions, curvature values: flat is no sign of a wrong view
    # imported when an image is blank: its 8 ms would slow every command's start (vgraph --help)
    from vgraph.blank_causes import diagnose
    processor_id = _target_processor(network, target)
    upstream = nx.shortest_path_length(network.graph.reverse(copy=False), processor_id)
    chain = [network.processors[pid] for pid in sorted(upstream, key=upstream.get)]  # nearest first
    size = (pixels.shape[1], pixels.shape[0])
    hidden = None  # the nearest renderer that shows nothing, said if none shows something
    for processor in chain:
        diagnosis = diagnose(network, processor, size)
        if diagnosis is not None and diagnosis.cause != "nothing_shown":
            return diagnosis.text
        hidden = hidden or diagnosis
    return hidden.text if hidden else None


def to_numpy(data):
    if data is None:
        raise VGraphError("the target holds no data (was it evaluated? is its input connected?)")
    if hasattr(data, "to_numpy"):
        return data.to_numpy()
    if hasattr(data, "data") and isinstance(data.data, np.ndarray):
        return data.data
    if isinstance(data, np.ndarray):
        return data
    raise VGraphError(f"cannot convert {type(data).__name__} to a numpy array")
