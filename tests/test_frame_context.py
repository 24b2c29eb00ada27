"""The frame context (vgraph.frame_context): what a frame needs that is not a property reaches the
processors that declare it as an argument of evaluation, and re-runs them when it changes."""

import json

import numpy as np
import pytest

from vgraph import FloatProperty, FrameContext, Inport, Network, Outport, Processor, VGraphError
from vgraph.bricks.cache import LoadLimit
from vgraph.bricks.selection import LeafPass

SIZE = (48, 40)


class Number:
    def __init__(self, value):
        self.value = value


class Limited(Processor):
    """A source whose output says which load limit its frame had."""
    outports = [Outport("value", Number)]
    uses_context = ("load_limit",)
    base = FloatProperty(1.0)

    def __init__(self, id=None, **values):
        super().__init__(id, **values)
        self.seen = []  # the contexts process() received, in order

    def process(self, context):
        self.seen.append(context)
        bricks = context.load_limit.bricks or 0 if context.load_limit is not None else 0
        return Number(self.base + bricks)


class Doubled(Processor):
    """Declares no context field: process() takes its inport only."""
    inports = [Inport("value", Number)]
    outports = [Outport("value", Number)]

    def process(self, value):
        return Number(2 * value.value)


class Constant(Processor):
    outports = [Outport("value", Number)]

    def process(self):
        return Number(5.0)


def network():
    net = Network()
    net.add(Limited("limited"))
    net.add(Doubled("doubled"))
    net.add(Constant("constant"))
    net.add(Doubled("other"))
    net.connect("limited.value", "doubled.value")
    net.connect("constant.value", "other.value")
    return net


def values(net, context=None):
    net.update("doubled.value", "other.value", context=context)
    return net.output("doubled.value").value, net.output("other.value").value


def counts(net):
    return {pid: p.evaluation_count for pid, p in net.processors.items()}


def test_a_declared_field_reaches_process_and_a_change_reruns_it_and_what_is_downstream():
    net = network()
    assert values(net) == (2.0, 10.0)
    assert net["limited"].seen == [FrameContext()]
    assert values(net, FrameContext(load_limit=LoadLimit(bricks=3))) == (8.0, 10.0)
    assert net["limited"].seen[-1].load_limit == LoadLimit(bricks=3)
    assert counts(net) == {"limited": 2, "doubled": 2, "constant": 1, "other": 1}
    # An equal limit (another object) is the same frame context: nothing runs again.
    values(net, FrameContext(load_limit=LoadLimit(bricks=3)))
    assert counts(net) == {"limited": 2, "doubled": 2, "constant": 1, "other": 1}
    # No context is a context without a limit: a change, so it runs again.
    assert values(net) == (2.0, 10.0)
    assert counts(net) == {"limited": 3, "doubled": 3, "constant": 1, "other": 1}
    assert net.last_evaluation.ids == ["limited", "doubled"]


def test_a_field_not_declared_is_not_seen_and_does_not_rerun():
    net = network()
    values(net)
    leaf = LeafPass(bricks=[])
    values(net, FrameContext(leaf=leaf))
    assert counts(net) == {"limited": 1, "doubled": 1, "constant": 1, "other": 1}
    assert net["limited"].seen == [FrameContext()]
    values(net, FrameContext(load_limit=LoadLimit(seconds=0.5), leaf=leaf))
    assert net["limited"].seen[-1] == FrameContext(load_limit=LoadLimit(seconds=0.5))  # the leaf narrowed away


def test_unhashable_fields_are_compared_by_identity():
    class Leafy(Processor):
        outports = [Outport("value", Number)]
        uses_context = ("leaf",)

        def process(self, context):
            return Number(len(context.leaf.bricks) if context.leaf else -1)

    net = Network()
    net.add(Leafy("leafy"))
    leaf = LeafPass(bricks=[1, 2])
    for context in (FrameContext(leaf=leaf), FrameContext(leaf=leaf)):
        net.update("leafy.value", context=context)
    assert net["leafy"].evaluation_count == 1
    net.update("leafy.value", context=FrameContext(leaf=LeafPass(bricks=[1, 2])))  # another task's leaf
    assert net["leafy"].evaluation_count == 2 and net.output("leafy.value").value == 2


def test_declarations_and_arguments_are_checked():
    with pytest.raises(ValueError, match="'tile' is not a FrameContext field"):
        type("Tiled", (Processor,), {"uses_context": ("tile",)})
    with pytest.raises(ValueError, match="inport named 'context' clashes"):
        type("Clash", (Processor,), {"uses_context": ("leaf",), "inports": [Inport("context", Number)]})
    with pytest.raises(ValueError, match="must be a tuple of field names"):
        type("Bare", (Processor,), {"uses_context": "leaf"})
    with pytest.raises(VGraphError, match="context must be a vgraph.frame_context.FrameContext, got dict"):
        network().update("doubled.value", context={"load_limit": None})


# --- the built-in users: no attribute is set on a processor from outside ----------------------------
def bricked_network(folder) -> Network:
    """A ball saved as .npy -> EntryExitPoints -> BrickedRayCaster 'rc' (mip, 16^3 bricks) ->
    Canvas, an oblique view."""
    from vgraph.camera import Camera
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in (37, 29, 41)], indexing="ij")
    np.save(folder / "ball.npy", np.clip(1.0 - np.sqrt(x * x + 1.3 * y * y + z * z), 0, 1).astype(np.float32))
    net = Network(base_dir=folder)
    net.add("VolumeSource", id="source", path="ball.npy")
    camera = Camera(position=(0.7, -0.5, 1.0), focus=(0, 0, 0), near=None, far=None, fit_to_data=True)
    net.add("EntryExitPoints", id="eep", camera=camera)
    net.add("BrickedRayCaster", id="rc", compositing="mip", brick_size=16, lod_bias=-16.0)
    net.add("Canvas", id="canvas", size=SIZE)
    net.link("eep.camera", "rc.camera")
    for source, target in (("source.volume", "eep.volume"), ("source.volume", "rc.volume"),
                           ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit"), ("rc.image", "canvas.image")):
        net.connect(source, target)
    return net


def test_the_leaves_split_gives_its_leaf_in_the_context(tmp_path):
    """The leaves split's tasks, run in this process: planned, drawn in two runs, composited and
    resolved, they give the single-process picture; the caster gets each task's leaf as its
    argument (no attribute is set on it), and a later frame without one is the whole frame again."""
    from vgraph.distributed.leaves import composite, plan_task, resolve_task, run_task
    from vgraph.distributed.worker import worker_network
    from vgraph.fileformat import network_document

    net = bricked_network(tmp_path)
    reference = net.evaluate("rc.image", size=SIZE)
    document, base_dir = json.dumps(network_document(net, tmp_path)), str(tmp_path)  # what a task carries
    common = (document, base_dir, "rc.image", SIZE, "rc", ())
    worker_net = worker_network(document, base_dir, "rc.image")[0]
    worker_net.update("rc.image", size=SIZE)
    caster = worker_net["rc"]
    attributes = set(vars(caster))
    bricks, _ = plan_task(*common)
    assert len(bricks) >= 4
    half = len(bricks) // 2
    layers = [run_task(*common, bricks[:half]), run_task(*common, bricks[half:])]
    picture = resolve_task(*common, composite(*layers, "mip"))
    np.testing.assert_allclose(picture, reference, atol=1e-6)
    assert set(vars(caster)) == attributes and "leaf" not in attributes and "load_limit" not in attributes
    assert caster.evaluated_context.leaf is not None  # the resolve task's: its argument, remembered
    worker_net.update("rc.image", size=SIZE)  # no leaf: the caster draws the whole frame again
    assert caster.evaluated_context == FrameContext() and caster.last_frame["bricks"] == len(bricks)
    np.testing.assert_allclose(worker_net.output("rc.image").to_numpy(), reference, atol=1e-6)


def test_the_render_process_gives_its_load_limit_in_the_context(tmp_path):
    from vgraph.live.render_messages import RenderJob
    from vgraph.live.render_server import RenderServer

    server = RenderServer()
    server.network = bricked_network(tmp_path)
    caster = server.network["rc"]
    result = server.handle(RenderJob(1, None, load_limit=LoadLimit(bricks=2)))
    assert result.error is None and result.refining
    assert caster.evaluated_context == FrameContext(load_limit=LoadLimit(bricks=2))
    assert "load_limit" not in vars(caster) and "leaf" not in vars(caster)
    writers = server.handle(RenderJob(1, None, load_limit=LoadLimit(bricks=2), include_writers=True))
    assert "rc" in writers.outcome.ran and caster.evaluated_context == FrameContext()  # complete frames
    assert caster.last_frame["complete"]
