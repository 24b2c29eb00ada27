"""The GUI's single seam for evaluation (no Qt here).

``Evaluator.run(network)`` decides what the GUI may evaluate and evaluates it. For now everything
runs in the GUI process, so only processors that need no OpenGL are evaluated; processors that
need GL are reported as ``deferred``: the render process (which owns the EGL context and sends
frames back as images) will take them over here, behind the same ``run`` call.

Conventions:
- A processor needs GL when its class says so (``uses_gl = True``/``False``) or, when it does not
  say, when one of its ports carries ``vgraph.image.Image`` (images are GPU textures).
- A processor is *ready* when its required inports are connected and everything upstream is ready;
  unready processors are not evaluated (they are not errors, only unfinished networks).
- File writers (sinks with a ``file_path`` property) do not run on every edit; they run when asked
  (``include_writers=True``), as the CLI runs them.
- One failing processor does not stop the others: each target is evaluated on its own and targets
  downstream of a failure are skipped (the scheduler would only retry and fail again).
- While evaluating, a guard context stands in for the GL context, so a processor that wrongly
  asks for GL fails with a clear message instead of creating a context in the GUI process.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field

import networkx as nx

from vgraph.errors import ProcessorError, VGraphError
from vgraph.image import Image
from vgraph.network import Network
from vgraph.processor import Processor
from vgraph.properties import FilePathProperty


def needs_gl(processor_type: type[Processor]) -> bool:
    if processor_type.uses_gl is not None:
        return processor_type.uses_gl
    ports = (*processor_type.inports, *processor_type.outports)
    return any(issubclass(port.data_type, Image) for port in ports)


def is_writer(processor_type: type[Processor]) -> bool:
    """A sink that writes a file: run on request, not on every edit."""
    return not processor_type.outports and any(
        isinstance(p, FilePathProperty) for p in processor_type.properties.values())


@dataclass
class EvaluationOutcome:
    ran: list[str] = field(default_factory=list)           # processors evaluated, in order
    failed: dict[str, str] = field(default_factory=dict)   # id -> reason
    deferred: list[str] = field(default_factory=list)      # need GL: the render process's job
    not_ready: list[str] = field(default_factory=list)     # required inports unconnected upstream
    writers: list[str] = field(default_factory=list)       # writers left for an explicit run


class Evaluator:
    """Evaluates what the GUI process may evaluate (see the module docstring)."""

    def run(self, network: Network, include_writers: bool = False) -> EvaluationOutcome:
        outcome = EvaluationOutcome()
        order = list(nx.topological_sort(network.graph))
        ready = self._ready(network, order)
        outcome.not_ready = [pid for pid in order if pid not in ready]
        in_process: set[str] = set()
        for pid in order:
            if pid not in ready:
                continue
            cls = type(network[pid])
            upstream_ok = all(u in in_process for u in network.graph.predecessors(pid))
            if needs_gl(cls) or not upstream_ok:
                outcome.deferred.append(pid)
            elif is_writer(cls) and not include_writers:
                outcome.writers.append(pid)
            else:
                in_process.add(pid)
        targets = [pid for pid in order if pid in in_process
                   and not any(s in in_process for s in network.graph.successors(pid))]
        with gl_forbidden():
            for target in targets:
                if any(a in outcome.failed for a in nx.ancestors(network.graph, target)):
                    continue
                try:
                    report = network.update(target)
                    outcome.ran.extend(report.ids)
                except ProcessorError as error:
                    outcome.ran.extend(network.last_evaluation.ids)
                    outcome.failed[error.processor_id] = error.reason
        return outcome

    @staticmethod
    def _ready(network: Network, order: list[str]) -> set[str]:
        ready: set[str] = set()
        for pid in order:
            processor = network[pid]
            connected = all(inport.optional or network.inputs_of(pid, inport.name)
                            for inport in processor.inports)
            if connected and all(u in ready for u in network.graph.predecessors(pid)):
                ready.add(pid)
        return ready


class _NoGLContext:
    """Stands in for the GL context in the GUI process: any use is a clear error."""

    def __getattr__(self, name):
        raise VGraphError("this processor needs OpenGL, which the GUI process does not have; it "
                          "must run in the render process (declare uses_gl = True on its class)")


@contextmanager
def gl_forbidden():
    """Install the stand-in context while evaluating, unless a real one already exists (only in
    processes that are not the GUI, e.g. a test run that also renders)."""
    from vgraph.gl import context
    if context.has_context():
        yield
        return
    context.set_context(_NoGLContext())
    try:
        yield
    finally:
        context.set_context(None)


# --- what a node shows --------------------------------------------------------------------------
@dataclass(frozen=True)
class ProcessorStatus:
    state: str    # "evaluated", "error", "invalid", "deferred", "not_ready", "writer"
    text: str     # one short line for the node
    detail: str   # the full story for a tooltip or the inspector


def processor_status(network: Network, processor: Processor) -> ProcessorStatus:
    """What a node shows about its processor's evaluation."""
    from vgraph.properties import Invalidation
    if processor.last_error:
        return ProcessorStatus("error", "error", processor.last_error)
    if processor.invalid_level == Invalidation.VALID and processor.evaluation_count:
        seconds = processor.last_seconds or 0.0
        return ProcessorStatus("evaluated", f"evaluated in {format_seconds(seconds)}",
                               f"up to date; ran {processor.evaluation_count} time"
                               f"{'s' * (processor.evaluation_count != 1)}, the last run took "
                               f"{format_seconds(seconds)}")
    missing = [p.name for p in processor.inports
               if not p.optional and not network.inputs_of(processor.id, p.name)]
    if missing:
        return ProcessorStatus("not_ready", "inport not connected",
                               f"required inports not connected: {', '.join(missing)}")
    if needs_gl(type(processor)):
        return ProcessorStatus("deferred", "needs the renderer",
                               "needs OpenGL: evaluated by the render process (not yet part of the GUI)")
    if is_writer(type(processor)):
        return ProcessorStatus("writer", "writes on request",
                               "writers run with Network > Run Writers, not on every edit")
    return ProcessorStatus("invalid", "not evaluated", "waiting for evaluation (or for its inputs)")


def format_seconds(seconds: float) -> str:
    return f"{seconds * 1000:.1f} ms" if seconds < 1 else f"{seconds:.2f} s"
