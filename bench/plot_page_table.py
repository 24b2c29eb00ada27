"""The figure of docs/explanations/bricked-ray-casting.md, "A page table of two levels": a frame's
plan over a volume one brick deep (so a slice shows it all), the leaf table that
vgraph.bricks.leaf_pages builds for it (the directory and its pages, from the real code), the brick
atlas's slots, and one sample of a ray looked up as the shader does (bricks/paged_sampling.glsl,
leaf_texel): directory entry -> page texel -> atlas slot.

    .venv/bin/python bench/plot_page_table.py [--out docs/images/bricked_page_table.png]
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import ConnectionPatch, Rectangle  # noqa: E402

from vgraph.bricks.leaf_pages import POINTER, build  # noqa: E402
from vgraph.bricks.pyramid import ArrayPyramid  # noqa: E402
from vgraph.bricks.brick_geometry import BrickGeometry  # noqa: E402

LEVEL_COLOURS = ["#6baed6", "#fd8d3c", "#74c476", "#9e9ac8", "#969696"]  # levels 0 to 4
BRICK, CELLS = 16, 16  # a 256 x 256 x 16 volume: 16 x 16 level-0 cells, one deep
DIRECTORY = 2          # the directory's level: 4 x 4 entries, pages of 4 x 4 level-0 cells


def the_frame(geometry: BrickGeometry):
    """A plan as a camera at the left makes it (level 0 near, 1 further, 2 far), cells outside a disc
    empty, and an atlas that misses a few planned cells (drawn from a coarser resident one)."""
    planned = []
    centre = np.array([128.0, 128.0])

    def walk(level, y, x):
        span = BRICK * 2 ** level
        lo = np.array([y, x]) * span
        nearest = np.clip(centre, lo, lo + span)
        if np.hypot(*(nearest - centre)) > 118.0:
            return  # outside the disc: empty, not planned
        wanted = 0 if x * span < 80 else (1 if x * span < 160 else 2)
        if level > wanted:
            for dy in range(2):
                for dx in range(2):
                    walk(level - 1, 2 * y + dy, 2 * x + dx)
        else:
            planned.append((level, 0, y, x))

    top = len(geometry.grids) - 1
    for y, x in np.ndindex(*geometry.grids[top][1::-1]):
        walk(top, y, x)
    missing = {(0, 0, 6, 3), (0, 0, 7, 3), (1, 0, 2, 4)}
    resident = [key for key in planned if key not in missing] + [(1, 0, 3, 1), (2, 0, 1, 1), (top, 0, 0, 0)]
    return planned, sorted(set(resident))


def draw(out: str) -> None:
    source = ArrayPyramid(np.zeros((BRICK, BRICK * CELLS, BRICK * CELLS), dtype=np.uint8), brick=(BRICK,) * 3)
    geometry = BrickGeometry(source)
    planned, resident = the_frame(geometry)
    slots = {key: slot for slot, key in enumerate(resident)}
    offsets = np.array([[slots[key], 0.0, 0.0] for key in resident])  # (the figure keeps the slot in r)
    leaf = build(geometry, planned, np.array(resident), offsets,
                 lambda level: np.zeros(tuple(geometry.grids[level][::-1])), slots=len(resident), directory=DIRECTORY)
    fig, (plan_ax, table_ax, atlas_ax) = plt.subplots(1, 3, figsize=(15, 5.6), width_ratios=[1.0, 1.25, 0.8])

    # The plan, in level-0 cells; the ray and its sample.
    for key in planned:
        level, _, y, x = key
        span = 2 ** level
        hatch = "//" if key not in slots else None
        plan_ax.add_patch(Rectangle((x * span, y * span), span, span, facecolor=LEVEL_COLOURS[level],
                                    edgecolor="black", lw=0.8, hatch=hatch, alpha=0.55 if hatch else 1.0))
    start, stop = np.array([0.3, 3.0]), np.array([15.7, 12.5])
    plan_ax.annotate("", stop, start, arrowprops={"arrowstyle": "->", "lw": 1.6})
    samples = start + np.linspace(0.05, 0.95, 14)[:, None] * (stop - start)
    plan_ax.plot(samples[:, 0], samples[:, 1], "k.", ms=4)
    sample = samples[3]
    plan_ax.plot(*sample, "o", color="crimson", ms=8)
    plan_ax.set(xlim=(0, CELLS), ylim=(0, CELLS), aspect="equal", title="the frame's plan (level-0 cells)")

    # The leaf table: the directory (z = 0) and the pages (z from the directory's depth on), layer 0 each.
    table = leaf.table
    directory = table[0, :geometry.grids[DIRECTORY][1], :geometry.grids[DIRECTORY][0]]

    def texel(entry, at, ax):
        a = entry[3]
        if a >= POINTER:
            colour = "#bbbbbb"
        elif a >= 1:
            colour = LEVEL_COLOURS[int(a) - 1]
        else:
            colour = "white"
        ax.add_patch(Rectangle(at, 1, 1, facecolor=colour, edgecolor="black", lw=0.6))
        if a >= POINTER:
            ax.text(at[0] + 0.5, at[1] + 0.5, "->", ha="center", va="center", fontsize=7)

    for y, x in np.ndindex(*directory.shape[:2]):
        texel(directory[y, x], (x, y), table_ax)
    origin_x, per_row = directory.shape[1] + 1.5, 3
    page_at = {}  # the page's texel origin (x, y, z) -> where the figure draws it
    pointers = [(y, x) for y, x in np.ndindex(*directory.shape[:2]) if directory[y, x, 3] >= POINTER]
    for number, (y, x) in enumerate(pointers):
        origin = tuple(int(v) for v in directory[y, x, :3])
        place = (origin_x + number % per_row * 5, number // per_row * 5)
        page_at[origin] = place
        for dy, dx in np.ndindex(*leaf.page_cells[1::-1]):
            texel(table[origin[2], origin[1] + dy, origin[0] + dx], (place[0] + dx, place[1] + dy), table_ax)
        table_ax.text(place[0] + 2, place[1] + 4.05, f"page of ({x}, {y})", ha="center", va="bottom", fontsize=7)
    grid = (5 * -(-len(pointers) // per_row), 5 * per_row)
    table_ax.set(xlim=(-0.5, origin_x + grid[1] + 0.5), ylim=(-0.5, max(grid[0], directory.shape[0]) + 0.5),
                 aspect="equal", title=f"leaf table: directory (level {DIRECTORY}) and pages")
    table_ax.text(0, directory.shape[0] + 0.1, "directory", fontsize=9, va="bottom")
    table_ax.text(origin_x, grid[0] + 0.1, f"{leaf.pages} pages of 4 x 4 level-0 cells", fontsize=9, va="bottom")
    table_ax.axis("off")

    # The sample's look-up: directory entry -> page texel -> atlas slot.
    cell = np.floor(sample).astype(int)  # (x, y)
    cells = leaf.page_cells[:2]
    home = cell // cells
    entry = directory[home[1], home[0]]
    page = entry[:3].astype(int)
    local = cell - home * cells
    drawn = table[page[2], page[1] + local[1], page[0] + local[0]]
    table_ax.add_patch(Rectangle(home, 1, 1, fill=False, edgecolor="crimson", lw=2.5))
    place = page_at[tuple(int(v) for v in page)]
    page_texel = (place[0] + local[0], place[1] + local[1])
    table_ax.add_patch(Rectangle(page_texel, 1, 1, fill=False, edgecolor="crimson", lw=2.5))
    for a, b, ax_a, ax_b in ((sample, home + 0.5, plan_ax, table_ax),
                             (home + 0.5, np.array(page_texel) + 0.5, table_ax, table_ax)):
        fig.add_artist(ConnectionPatch(b, a, "data", "data", axesA=ax_b, axesB=ax_a, color="crimson",
                                       arrowstyle="<-", lw=1.4, connectionstyle="arc3,rad=-0.25"))

    # The atlas: a slot per resident brick.
    per_row = 10
    for key, slot in slots.items():
        xy = (slot % per_row, slot // per_row)
        atlas_ax.add_patch(Rectangle(xy, 0.9, 0.9, facecolor=LEVEL_COLOURS[key[0]], edgecolor="black", lw=0.6))
    slot = int(round(drawn[0]))
    target = np.array([slot % per_row, slot // per_row]) + 0.45
    atlas_ax.add_patch(Rectangle(target - 0.45, 0.9, 0.9, fill=False, edgecolor="crimson", lw=2.5))
    key = resident[slot]
    atlas_ax.text(target[0], target[1] - 0.6, f"brick ({key[0]}: {key[2]}, {key[3]})", ha="center", va="top",
                  fontsize=8, color="crimson", bbox={"fc": "white", "ec": "none"})
    fig.add_artist(ConnectionPatch(target, np.array(page_texel) + 0.5, "data", "data", axesA=atlas_ax,
                                   axesB=table_ax, color="crimson", arrowstyle="<-", lw=1.4,
                                   connectionstyle="arc3,rad=0.2"))
    rows = -(-len(slots) // per_row)
    atlas_ax.set(xlim=(-0.2, per_row), ylim=(-1.5, rows + 0.2), aspect="equal",
                 title="brick atlas: a slot per resident brick")
    atlas_ax.axis("off")
    plan_ax.set_xticks([]), plan_ax.set_yticks([])
    handles = [Rectangle((0, 0), 1, 1, facecolor=c, edgecolor="black") for c in LEVEL_COLOURS]
    handles += [Rectangle((0, 0), 1, 1, facecolor="#bbbbbb", edgecolor="black"),
                Rectangle((0, 0), 1, 1, facecolor="white", edgecolor="black", hatch="//"),
                Rectangle((0, 0), 1, 1, facecolor="white", edgecolor="black")]
    fig.legend(handles, [f"level {n}" for n in range(len(LEVEL_COLOURS))]
               + ["pointer to a page", "missing: drawn from a coarser resident brick", "empty: nothing drawn"],
               loc="lower center", ncol=8,
               frameon=False)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    fig.savefig(out, dpi=110)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/images/bricked_page_table.png")
    draw(parser.parse_args().out)


if __name__ == "__main__":
    main()
