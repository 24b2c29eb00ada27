"""Make docs/images/sweep_plane_algorithm.png: RZSweep's algorithm drawn on a 2D grid
(docs/explanations/sweep-plane.md, "The algorithm").

    .venv/bin/python bench/make_sweep_figure.py [--out docs/images/sweep_plane_algorithm.png] [--event 9]

The figure is computed, not drawn by hand: the script runs the sweep of vgraph.sweep.kernel in 2D
(vertices, edges for faces, an orthographic camera whose rays cross the grid obliquely) with the
kernel's rules: a heap keyed by depth seeded with the nearest vertex, each vertex sending its
unsent neighbours; a face (here an edge) projected at the event of its nearer vertex, inserting
(t, scalar) into the list of every pixel whose ray crosses it; a target z set to the farthest
neighbour's depth of the vertex popped when the plane has passed the last target, and at that
event every list composited up to the plane. Panel (a) is the grid at one event (``--event``),
(b) the per-pixel lists at that moment, (c) the whole sweep: each event's depth in heap order, the
target-z events and how many list entries were held."""

from __future__ import annotations

import argparse
import heapq
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")   # no display: the script runs headless like the rest of bench/
import matplotlib.pyplot as plt  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "images" / "sweep_plane_algorithm.png"
NX, NY = 5, 4                                   # vertices (4 x 3 cells)
VIEW = np.array([0.42, 1.0]) / np.hypot(0.42, 1.0)  # the camera looks up and to the right
PIXELS = 8
NEAR = -1.2                                     # depth of the image line


@dataclass
class Snapshot:
    plane: float
    target: float
    swept: set
    in_heap: set
    projected: list
    lists: list                  # per pixel: pending (t, vertex-edge) entries
    composited: list             # per pixel: t of the entries already composited


@dataclass
class Sweep:
    order: list = field(default_factory=list)     # popped vertices, heap order
    depths: list = field(default_factory=list)
    flushes: list = field(default_factory=list)   # event index of each target-z event
    held: list = field(default_factory=list)      # list entries held after each event
    snapshot: Snapshot | None = None


def vertices() -> np.ndarray:
    x, y = np.meshgrid(np.arange(NX, dtype=float), np.arange(NY, dtype=float), indexing="xy")
    return np.stack([x.ravel(), y.ravel()], axis=1)   # index = j * NX + i


def neighbours(v: int) -> list[int]:
    i, j = v % NX, v // NX
    out = [(i + di, j + dj) for di, dj in ((-1, 0), (1, 0), (0, -1), (0, 1))]
    return [b * NX + a for a, b in out if 0 <= a < NX and 0 <= b < NY]


def pixel_rays(points: np.ndarray) -> np.ndarray:
    """Ray origins on the image line (depth NEAR), spread over the grid's projection."""
    across = np.array([VIEW[1], -VIEW[0]])
    lateral = points @ across
    offsets = np.linspace(lateral.min() + 0.3, lateral.max() - 0.3, PIXELS)
    return offsets[:, None] * across + NEAR * VIEW


def crossing(origin, a, b) -> float | None:
    """Ray parameter t where the ray from origin along VIEW crosses segment a-b, or None."""
    matrix = np.array([VIEW, a - b]).T
    if abs(np.linalg.det(matrix)) < 1e-12:
        return None
    t, s = np.linalg.solve(matrix, a - origin)
    return float(t) if 0.0 <= s <= 1.0 else None


def run_sweep(points: np.ndarray, origins: np.ndarray, snapshot_event: int) -> Sweep:
    depth = points @ VIEW
    result = Sweep()
    swept, sent = set(), {int(np.argmin(depth))}
    heap = [(depth[v], v) for v in sent]
    lists = [[] for _ in origins]
    composited = [[] for _ in origins]
    projected = []
    target = -np.inf
    while heap or target < np.inf:
        plane = heap[0][0] if heap else np.inf
        if plane >= target:                      # a target-z event: composite up to the plane
            result.flushes.append(len(result.order))
            for p, entries in enumerate(lists):
                done = [e for e in entries if NEAR + e <= plane]
                composited[p] += done
                lists[p] = [e for e in entries if NEAR + e > plane]
            if not heap:
                break
        _, v = heapq.heappop(heap)
        swept.add(v)
        if plane >= target:                      # the next target: the farthest neighbour
            target = max([plane] + [depth[n] for n in neighbours(v)])
        for n in neighbours(v):
            if n not in sent:
                sent.add(n)
                heapq.heappush(heap, (depth[n], n))
            if n not in swept:                   # the edge's nearer end: project it now
                projected.append((v, n))
                for p, origin in enumerate(origins):
                    t = crossing(origin, points[v], points[n])
                    if t is not None:
                        lists[p] = sorted(lists[p] + [t])
        result.order.append(v)
        result.depths.append(plane)
        result.held.append(sum(len(entries) for entries in lists))
        if len(result.order) == snapshot_event:
            result.snapshot = Snapshot(plane, target, set(swept), {v for _, v in heap}, list(projected),
                                       [list(e) for e in lists], [list(c) for c in composited])
    return result


def draw_grid(ax, points, origins, sweep: Sweep) -> None:
    snap = sweep.snapshot
    across = np.array([VIEW[1], -VIEW[0]])
    for a in range(len(points)):
        for b in neighbours(a):
            if a < b:
                ax.plot(*points[[a, b]].T, color="0.8", lw=1, zorder=1)
    for a, b in snap.projected:
        ax.plot(*points[[a, b]].T, color="tab:blue", lw=2.5, zorder=2)
    reach = float((points @ VIEW).max()) - NEAR + 0.4
    for origin in origins:
        ax.plot(*np.array([origin, origin + reach * VIEW]).T, color="0.45", lw=0.8, ls=":", zorder=1)
    for p, origin in enumerate(origins):
        for t in snap.composited[p]:
            ax.plot(*(origin + t * VIEW), "x", color="0.35", ms=5, zorder=4)
        for t in snap.lists[p]:
            ax.plot(*(origin + t * VIEW), "o", color="tab:blue", ms=4, zorder=4)
    for depth, style, label in ((snap.plane, "-", "sweep plane"), (snap.target, "--", "target z")):
        centre = depth * VIEW + float((points @ across).mean()) * across
        ends = np.array([centre - 3.0 * across, centre + 3.0 * across])
        ax.plot(*ends.T, color="tab:red", ls=style, lw=1.8, zorder=3, label=label)
    for rank, v in enumerate(sweep.order):
        colour = "black" if v in snap.swept else ("tab:orange" if v in snap.in_heap else "white")
        ax.plot(*points[v], "o", ms=13, mfc=colour, mec="black", zorder=5)
        text_colour = "white" if v in snap.swept else "black"
        ax.text(*points[v], str(rank + 1), ha="center", va="center", fontsize=7, color=text_colour, zorder=6)
    line = np.array([origins[0] - 0.4 * across, origins[-1] + 0.4 * across])
    ax.plot(*line.T, color="black", lw=3)
    ax.text(*(line.mean(axis=0) - 0.2 * VIEW), "image line (pixels), rays along the view",
            ha="center", va="top", fontsize=8, rotation=np.degrees(np.arctan2(across[1], across[0])),
            rotation_mode="anchor")
    ax.annotate("", xy=origins[0] + 1.0 * VIEW, xytext=origins[0], arrowprops={"arrowstyle": "->"})
    ax.plot([], [], "o", mfc="black", mec="black", label="swept")
    ax.plot([], [], "o", mfc="tab:orange", mec="black", label="in the heap")
    ax.plot([], [], color="tab:blue", lw=2.5, label="faces projected")
    ax.plot([], [], "o", color="tab:blue", ms=4, label="list entries (t, s)")
    ax.plot([], [], "x", color="0.35", label="composited")
    ax.set_aspect("equal")
    ax.axis("off")
    ax.legend(loc="lower right", fontsize=7, frameon=False)
    ax.set_title(f"(a) the grid after event {len(snap.swept)}: vertices numbered in heap order",
                 fontsize=9)


def draw_lists(ax, sweep: Sweep) -> None:
    snap = sweep.snapshot
    for p in range(PIXELS):
        ax.plot(snap.composited[p], [p] * len(snap.composited[p]), "x", color="0.35")
        ax.plot(snap.lists[p], [p] * len(snap.lists[p]), "o", color="tab:blue")
        if snap.composited[p]:
            ax.plot([0, snap.composited[p][-1]], [p, p], color="0.6", lw=4, alpha=0.5, zorder=0)
    ax.axvline(snap.plane - NEAR, color="tab:red", lw=1.8)
    ax.axvline(snap.target - NEAR, color="tab:red", ls="--", lw=1.8)
    ax.text(snap.target - NEAR, PIXELS - 0.4, " next flush:\n composite up to here", fontsize=7,
            color="tab:red", va="top")
    ax.set_yticks(range(PIXELS))
    ax.set_ylim(-0.7, PIXELS - 0.3)
    ax.set_xlabel("t along the pixel's ray (sorted lists)", fontsize=8)
    ax.set_ylabel("pixel", fontsize=8)
    ax.set_title("(b) per-pixel lists at that event: grey bar = composited,\n"
                 "blue = waiting; each segment between entries is one cell's", fontsize=9)


def draw_events(ax, sweep: Sweep) -> None:
    events = np.arange(1, len(sweep.order) + 1)
    ax.plot(events, np.array(sweep.depths) - NEAR, "o-", color="black", ms=3, lw=0.8,
            label="depth of the popped vertex")
    for i, flush in enumerate(sweep.flushes):
        ax.axvline(flush + 0.5, color="tab:red", ls="--", lw=1, label="target-z event" if i == 0 else None)
    held = ax.twinx()
    held.step(events, sweep.held, where="post", color="tab:blue", lw=1.2)
    held.set_ylabel("list entries held", fontsize=8, color="tab:blue")
    ax.axvline(len(sweep.snapshot.swept), color="0.5", lw=4, alpha=0.3, label="(a), (b)")
    ax.set_xlabel("event (vertex popped from the heap)", fontsize=8)
    ax.set_ylabel("depth along the view", fontsize=8)
    ax.legend(loc="upper left", fontsize=7, frameon=False)
    ax.set_title("(c) the whole sweep: events in depth order; lists composited\n"
                 "and freed at each target z, so few entries are held", fontsize=9)


def draw(path: Path, snapshot_event: int) -> None:
    points = vertices()
    origins = pixel_rays(points)
    sweep = run_sweep(points, origins, snapshot_event)
    assert sweep.depths == sorted(sweep.depths)   # the heap hands the vertices out in depth order
    fig = plt.figure(figsize=(14, 5.2))
    grid = fig.add_gridspec(1, 3, width_ratios=[1.4, 1, 1])
    draw_grid(fig.add_subplot(grid[0]), points, origins, sweep)
    draw_lists(fig.add_subplot(grid[1]), sweep)
    draw_events(fig.add_subplot(grid[2]), sweep)
    fig.suptitle("RZSweep in 2D (Retondaro 2008; ZSweep, Farias et al. 2000): a plane sweeps the grid "
                 "front to back over its vertices", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--event", type=int, default=9, help="the event panels (a) and (b) show")
    args = parser.parse_args()
    draw(args.out, args.event)
    print(args.out)


if __name__ == "__main__":
    main()
