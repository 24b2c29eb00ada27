"""The leaves split (sort-last, issue #15): the bricks of one BrickedRayCaster frame are divided
among the workers, each ray-casts its bricks into a partial accumulation, and the partials are
composited in visibility order on the workers before the frame is resolved once.

- Plan: one task builds the network on a worker and plans the frame there (selection.plan_frame,
  through the processor itself: the plan needs the transfer function's LUT, i.e. a GL context,
  which the client never creates). It returns the planned bricks, front to back, with their
  weights: the voxels of each brick (all planned bricks are non-empty by their ranges).
- Runs: the front-to-back list is cut into contiguous runs of about equal weight, one per worker
  (``split_runs``). A contiguous run composites into one partial image that is exactly one layer
  in visibility order, because every sample lies in exactly one brick and the order is per pixel
  front to back (docs/explanations/bricked-ray-casting.md).
- Partials: each run task draws its bricks (a selection.LeafPass, given to the caster in the frame
  context, vgraph.frame_context) and returns the accumulation before the resolve pass: (sum,
  first), float32 [H, W, 4] each. dvr and iso: premultiplied colour and
  the first depth sample, both blended "under"; mip: (maximum, its sample) decided by the depth
  test on 1 - maximum.
- Composite: adjacent layers are combined pairwise as Dask tasks (a tree of depth log2(runs)), so
  the partial images stay on the workers; only the final picture reaches the client.
- Resolve: a last task puts the composited accumulation into the processor and evaluates the
  target: the resolve pass (background, mip's classification, depth) and everything downstream
  run once, as in one process.
- A SweepPlaneRenderer (RZSweep) over a store is split alike: its plan is the store's leaves front
  to back, a run task sweeps its run of leaves into a partial (colour, log transparency, first t,
  segments), partials composite front over back (vgraph.sweep.leaves.composite) and the resolve
  task finishes the picture over the background. Its runs stop their rays at their own opacity
  (early termination): within 1 - early_termination of one process (vgraph.sweep.leaves.composite).
- Costs: each task reports what its worker's brick caches read and its seconds
  (vgraph.distributed.report.measured); they travel with the partials through the composite tree
  (a few numbers) and reach the client with the picture.
"""

from __future__ import annotations

import uuid

import networkx as nx
import numpy as np

from vgraph.bricks.cache import brick_extent
from vgraph.bricks.selection import LeafPass
from vgraph.distributed.report import ClusterFrame, counted_reads, measured, task_report
from vgraph.distributed.tiles import TileError
from vgraph.distributed.watch import results, watch
from vgraph.distributed.worker import GL_LOCK, kept_networks, load_plugins, shipped, worker_network
from vgraph.frame_context import FrameContext
from vgraph.sweep import leaves as sweep_leaves

KIND = "BrickedRayCaster"
SWEEP = "SweepPlaneRenderer"  # RZSweep: runs of a store's leaves, partials composited alike
KINDS = (KIND, SWEEP)
DEPTH_STEPS = 2 ** 24 - 1  # the accumulation's depth texture (mip's test on 1 - maximum): 24-bit


# --- the client's side ---------------------------------------------------------------------------
def bricked_caster(network, target: str) -> str:
    """The id of the one BrickedRayCaster (or SweepPlaneRenderer, whose bricks are a store's
    leaves) the target needs, refused (TileError) when there is none, several, or one whose bricks
    cannot be composited independently."""
    processor_id = target.partition(".")[0]
    needed = sorted({processor_id, *nx.ancestors(network.graph, processor_id)})
    casters = [pid for pid in needed if network[pid].type_name in KINDS]
    if len(casters) != 1:
        found = "none" if not casters else ", ".join(f"'{pid}'" for pid in casters)
        raise TileError(f"the leaves split divides the bricks of one BrickedRayCaster (or the leaves of "
                        f"one SweepPlaneRenderer) among the workers; {target} needs {found} (use split='tiles')")
    caster = network[casters[0]]
    values = caster.property_values
    if compositing(caster) == "dvr" and values.get("early_termination", 1.0) < 1.0:
        # A run cannot know how opaque the runs in front of it are, so it cannot stop its rays
        # where one process would. (RZSweep's runs stop at their own opacity, which is within
        # 1 - early_termination of one sweep: vgraph.sweep.leaves.composite; the same for the
        # GL passes is not done: their bricks' early termination reads the accumulation.)
        raise TileError(f"{casters[0]}.early_termination: {values['early_termination']:g} stops rays "
                        "by what the bricks in front left, which a worker's run of bricks cannot see; "
                        "set it to 1 for the leaves split (or use split='tiles')")
    return casters[0]


def split_runs(weights, count: int) -> list[tuple[int, int]]:
    """[start, stop) of ``count`` contiguous runs of ``weights`` (front to back) of about equal
    sum: run k ends where the cumulative weight is nearest k / count of the total. Fewer runs when
    there are fewer items; none for none."""
    weights = np.asarray(weights, dtype=np.float64)
    n = len(weights)
    count = max(1, min(int(count), n))
    if n == 0:
        return []
    cumulative = np.concatenate([[0.0], np.cumsum(weights)])
    bounds = [0]
    for k in range(1, count):
        goal = cumulative[-1] * k / count
        end = int(np.argmin(np.abs(cumulative - goal)))
        # Every run keeps at least one brick: after the previous cut, before the remaining runs'.
        bounds.append(min(max(end, bounds[-1] + 1), n - (count - k)))
    bounds.append(n)
    return list(zip(bounds[:-1], bounds[1:]))


def render_leaves(plan, client, runs: int | None = None, plugins=(), timeout=None,
                  cluster: str | None = None) -> ClusterFrame:
    """The picture of ``plan`` (render.Plan) drawn by the leaves split, with what each task read
    (vgraph.distributed.report); ``runs``: brick runs (default: one per worker); ``timeout`` and
    ``cluster`` as render() takes them."""
    caster = bricked_caster(plan.network, plan.target)
    document, base_dir = shipped(plan.network)
    plugins = tuple(plugins)
    common = (document, base_dir, plan.target, plan.size, caster, plugins)
    # Unique per call (a changed file with the same name is new work); a retried task keeps its
    # key and recomputes the same value from its arguments alone.
    token = uuid.uuid4().hex[:12]
    mode = compositing(plan.network[caster])
    stop_at = float(plan.network[caster].property_values.get("early_termination", 1.0))
    planning_label = "the plan of the frame's bricks"
    planned = client.submit(measured, plan_task, *common, pure=False, key=f"vgraph-leaves-{token}-plan")
    planning = {planned: planning_label}
    watch(client, planning, timeout, cluster)
    [((bricks, weights), plan_costs)] = results(client, planning, cluster)
    workers = sorted(client.scheduler_info().get("workers", {}))
    pieces = split_runs(weights, runs or max(1, len(workers)))
    layers, tasks = [], {}
    for i, (start, stop) in enumerate(pieces):
        # Run i goes to the i-th worker (sorted addresses): the same run of the same network lands
        # on the worker that holds its network and bricks, frame after frame. The restriction is
        # loose, so the run moves to another worker when that one is gone (killed, replaced).
        place = {"workers": [workers[i % len(workers)]], "allow_other_workers": True} if workers else {}
        label = f"run {i + 1} of {len(pieces)} (bricks {start + 1}-{stop} of {len(bricks)})"
        layers.append(client.submit(run_layer, label, *common, bricks[start:stop], pure=False,
                                    key=f"vgraph-leaves-{token}-run{i}", **place))
        tasks[layers[-1]] = label
    level = 0
    while len(layers) > 1:  # adjacent layers pairwise, front before back: the visibility order
        level += 1
        layers = [client.submit(combine, *layers[j:j + 2], mode, stop_at,
                                f"composite {j // 2 + 1} of level {level}", pure=False,
                                key=f"vgraph-leaves-{token}-composite{level}-{j // 2}")
                  if j + 1 < len(layers) else layers[j] for j in range(0, len(layers), 2)]
        tasks.update({layer: f"composite {j + 1} of level {level}" for j, layer in enumerate(layers)
                      if layer not in tasks})
    accumulated = layers[0] if layers else None
    resolved = client.submit(resolve_layer, *common, accumulated, pure=False,
                             key=f"vgraph-leaves-{token}-resolve")
    tasks[resolved] = "the resolve pass"
    watch(client, tasks, timeout, cluster)
    picture, costs = results(client, {resolved: tasks[resolved]}, cluster)[0]
    reports = (task_report(planning_label, plan_costs), *(task_report(c["task"], c) for c in costs))
    return ClusterFrame(picture, "leaves", reports)


# --- the layers: partial accumulations with what their tasks cost (on the workers) -----------------
def run_layer(label, *arguments) -> tuple:
    """(run_task's accumulation, [its costs]): a layer of the composite tree."""
    partial, costs = measured(run_task, *arguments)
    return partial, [{**costs, "task": label}]


def combine(front: tuple, back: tuple, mode: str, early_termination: float, label: str) -> tuple:
    """Two adjacent layers -> one (``composite``), their tasks' costs in front-to-back order."""
    together, costs = measured(composite, front[0], back[0], mode, early_termination)
    return together, [*front[1], {**costs, "task": label}, *back[1]]


def resolve_layer(*arguments) -> tuple:
    """(resolve_task's picture, the costs of every task of the frame after the plan)."""
    *common, layer = arguments
    accumulated, costs = (None, []) if layer is None else layer
    picture, own = measured(resolve_task, *common, accumulated)
    return picture, [*costs, {**own, "task": "the resolve pass"}]


# --- compositing (pure numpy; on the workers) --------------------------------------------------------
def compositing(processor) -> str:
    """How the caster's partials composite: its compositing mode, or "sweep" for RZSweep's."""
    return "sweep" if processor.type_name == SWEEP else processor.compositing


def composite(front: tuple, back: tuple, mode: str, early_termination: float = 1.0) -> tuple:
    """Two partial accumulations (sum, first) of adjacent runs -> the accumulation of both, as the
    single process's brick passes leave it ("sweep": RZSweep's partials, vgraph.sweep.leaves,
    where the back is left out of pixels the front made opaque to ``early_termination``)."""
    if mode == "sweep":
        return sweep_leaves.composite(front, back, early_termination)
    front_sum, front_first = front
    back_sum, back_first = back
    if mode == "mip":
        # The depth test (LESS on 1 - maximum, a 24-bit depth texture cleared to 1): the back
        # run's maximum wins only where it is larger at that precision; a tie keeps the front.
        front_depth = np.where(front_sum[..., 3] > 0, _depth(front_sum[..., 0]), DEPTH_STEPS)
        back_depth = np.where(back_sum[..., 3] > 0, _depth(back_sum[..., 0]), DEPTH_STEPS)
        take = (back_depth < front_depth)[..., None]
        return np.where(take, back_sum, front_sum), np.where(take, back_first, front_first)
    # dvr and iso: the passes' blending "under" (ONE_MINUS_DST_ALPHA, ONE) on both targets:
    # colour C += (1 - A) C_back; the first depth sample (alpha 1 where set) stays the front's.
    return _under(front_sum, back_sum), _under(front_first, back_first)


def _under(front: np.ndarray, back: np.ndarray) -> np.ndarray:
    # IEEE arithmetic as the GL blend does it (llvmpipe, measured): an iso brick's refined depth
    # sample can be inf or NaN, and 0 * inf = NaN reaches the accumulation behind a front hit in
    # one process too, so it does here (numpy need not warn about it).
    with np.errstate(invalid="ignore", over="ignore"):
        return (front + (np.float32(1.0) - front[..., 3:4]) * back).astype(np.float32)


def _depth(maximum: np.ndarray) -> np.ndarray:
    return np.rint((1.0 - maximum.astype(np.float64)) * DEPTH_STEPS)


# --- the tasks (in worker processes) -----------------------------------------------------------------
def plan_task(document, base_dir, target, size, caster, plugins) -> tuple[list, list]:
    """(the planned bricks (key, rect) front to back, their weights: voxels of each brick)."""
    def planned(processor, leaf):
        source = processor.brick_source(processor.inputs["volume"])
        bricks = [(tuple(int(v) for v in key), tuple(int(v) for v in rect)) for key, rect in leaf.plan.bricks]
        weights = [int(np.prod(stop - start)) for start, stop in (brick_extent(source, key) for key, _ in bricks)]
        return bricks, weights

    return _draw(document, base_dir, target, size, caster, plugins, planned, bricks=[])


def run_task(document, base_dir, target, size, caster, plugins, bricks) -> tuple:
    """The (sum, first) accumulation of ``bricks`` (a contiguous run of the plan)."""
    return _draw(document, base_dir, target, size, caster, plugins, lambda _, leaf: leaf.partial,
                 bricks=[(tuple(key), tuple(rect)) for key, rect in bricks])


def resolve_task(document, base_dir, target, size, caster, plugins, accumulated) -> np.ndarray:
    """The target's picture, float32 (H, W, 4), row 0 at the top, from the composited
    accumulation (None: the frame has no bricks, so none are drawn)."""
    def picture(network):
        return np.ascontiguousarray(network.output(target).to_numpy(), dtype=np.float32)

    leaf = {"bricks": []} if accumulated is None else {"accumulated": accumulated}
    return _draw(document, base_dir, target, size, caster, plugins, None, output=picture, **leaf)


def _draw(document, base_dir, target, size, caster, plugins, result, output=None, **leaf_values):
    """Evaluate the shipped network with a LeafPass(**leaf_values) in the frame context, up to the
    caster's image and return ``result(processor, leaf)``, or up to the target and return
    ``output(network)``. The leaf is this evaluation's argument, not the processor's state: the
    caster (and what is downstream) runs again for each task's new leaf and for a later task
    without one, so a retried or later task on this worker starts afresh: tasks are idempotent."""
    load_plugins(plugins)
    with GL_LOCK, counted_reads(kept_networks):
        network, full_cameras = worker_network(document, base_dir, target)
        for address, camera in full_cameras.items():  # a tiles task may have left a tile's camera
            network.set(address, camera)
        leaf = LeafPass(**leaf_values)
        context = FrameContext(leaf=leaf)
        try:
            if output is not None:
                network.update(target, size=tuple(size), context=context)
                return output(network)
            network.update(f"{caster}.image", size=tuple(size), context=context)
            return result(network[caster], leaf)
        finally:  # the caster remembers its last context until the next task: not the arrays
            leaf.accumulated = leaf.partial = None
