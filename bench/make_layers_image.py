"""Make docs/images/architecture_layers.png: the layers of vgraph's code as pyproject.toml's
import-linter contracts fix them (docs/explanations/architecture.md, "Layers").

    .venv/bin/python bench/make_layers_image.py [--out docs/images/architecture_layers.png]

The picture is drawn from the lists below: ``LAYERS`` (highest first; a layer imports only from its
own layer and those below), ``RULES`` (the forbidden contracts, written under the layers) and
``SIDE`` (boxes in the right-hand column, kept free for the ray casters' component contract). To
change the picture, change a list and run the script again; tests/test_import_layers.py checks the
contracts themselves, this only draws them."""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")   # no display: the script runs headless like the rest of bench/
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "images" / "architecture_layers.png"


@dataclass
class Box:
    name: str            # the module or package, as vgraph.<name>
    note: str = ""       # one short line under the name


@dataclass
class Layer:
    title: str
    boxes: list[Box]
    colour: str


@dataclass
class SideBox:
    """A box of the right-hand column: a title and a few lines."""
    title: str
    lines: list[str] = field(default_factory=list)


LAYERS = [
    Layer("applications", [Box("cli", "the vgraph command"), Box("gui", "the Qt views"),
                           Box("live", "the render side, no Qt"), Box("distributed", "a Dask cluster"),
                           Box("notebook", "Jupyter")], "#dbe8f6"),
    Layer("processors : shaders", [Box("processors", "the built-in processors"),
                                   Box("shaders", "their GLSL, composed from includes")], "#e3f1dc"),
    Layer("rendering, files and numerics", [Box("gl", "passes, ray casting"), Box("io", "data files"),
                                            Box("bricks", "bricked volumes"), Box("numerics", "CPU references"),
                                            Box("implicit", "implicit functions"),
                                            Box("fileformat", "network files, ...")], "#fbefd5"),
    Layer("the model", [Box("network", "the graph, its events"), Box("processor", "ports, properties"),
                        Box("scheduler", "what runs"), Box("volume", "image, mesh, ..."),
                        Box("derived", "one cache"), Box("frame_context", "per-frame context")], "#f3e0e6"),
]

RULES = [
    "A module imports only from its own layer and those below it (\"a : b\" siblings, one way only).",
    "No Qt (PySide6) in live, distributed and the layers below; live never imports gui (its views).",
    "No import circle between the top-level parts, nor inside a package.",
]

# The right-hand column: the ray casters' component contract (architecture.md, "Ray casters are
# lists of components"); the components live in gl (raycasting), the ray casters in processors.
SIDE: list[SideBox] = [
    SideBox("a component declares", ["inports    EntryExit: entry, exit", "properties declare()",
                                     "GLSL       glsl: segments", "binding    bind(frame): defines,",
                                     "           textures, uniforms"]),
    SideBox("built with what it needs", ["Light(mode, shaded_modes)", "FrontToBack(mode, corrected)",
                                         "EmptySpace(skip=...)", "TransferFunctionLut(channels=n)"]),
    SideBox("a ray caster", ["= its components + its own part", "process(): own defines, targets,",
                             "   then draw(): the parts' GLSL", "   included ahead of its shader"]),
]

WIDTH, HEIGHT = 14.0, 7.6     # inches at 100 dpi: 1400 x 760 pixels
LAYERS_RIGHT = 0.70           # the layers take the left 70 %; the rest is SIDE's
ROW_HEIGHT, ROW_GAP, TOP = 0.155, 0.035, 0.93


def draw_layer(ax, layer: Layer, top: float) -> None:
    left, right = 0.07, LAYERS_RIGHT
    ax.add_patch(FancyBboxPatch((left, top - ROW_HEIGHT), right - left, ROW_HEIGHT,
                                boxstyle="round,pad=0.004", facecolor=layer.colour, edgecolor="#555555"))
    ax.text(left + 0.008, top - 0.018, layer.title, fontsize=11, fontweight="bold", va="top")
    inner_left, inner_right = left + 0.01, right - 0.01
    width = (inner_right - inner_left) / len(layer.boxes)
    for i, box in enumerate(layer.boxes):
        x = inner_left + i * width
        ax.add_patch(FancyBboxPatch((x + 0.004, top - ROW_HEIGHT + 0.014), width - 0.008, ROW_HEIGHT - 0.06,
                                    boxstyle="round,pad=0.003", facecolor="white", edgecolor="#777777"))
        centre = x + width / 2
        ax.text(centre, top - ROW_HEIGHT + 0.073, box.name, fontsize=10.5, ha="center", family="monospace")
        ax.text(centre, top - ROW_HEIGHT + 0.038, box.note, fontsize=8.5, ha="center", color="#333333")


def draw_side(ax, boxes: list[SideBox]) -> None:
    left, right, top = LAYERS_RIGHT + 0.03, 0.98, TOP
    height = (TOP - 0.06) / max(len(boxes), 1) - 0.02
    for box in boxes:
        ax.add_patch(FancyBboxPatch((left, top - height), right - left, height, boxstyle="round,pad=0.004",
                                    facecolor="#eeeeee", edgecolor="#555555"))
        ax.text(left + 0.01, top - 0.02, box.title, fontsize=11, fontweight="bold", va="top")
        for j, line in enumerate(box.lines):
            ax.text(left + 0.01, top - 0.06 - 0.032 * j, line, fontsize=9, va="top", family="monospace")
        top -= height + 0.02


def draw(path: Path) -> None:
    fig = plt.figure(figsize=(WIDTH, HEIGHT), dpi=100)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    ax.axis("off")
    ax.text(0.07, 0.975, "vgraph's layers (pyproject.toml, [tool.importlinter])", fontsize=13,
            fontweight="bold", va="top")
    top = TOP
    for layer in LAYERS:
        draw_layer(ax, layer, top)
        top -= ROW_HEIGHT + ROW_GAP
    bottom = top + ROW_GAP
    ax.add_patch(FancyArrowPatch((0.035, TOP - 0.01), (0.035, bottom + 0.01), arrowstyle="-|>",
                                 mutation_scale=22, color="#444444", linewidth=2))
    ax.text(0.022, (TOP + bottom) / 2, "imports", rotation=90, fontsize=11, ha="center", va="center")
    for j, rule in enumerate(RULES):
        ax.text(0.07, bottom - 0.03 - 0.032 * j, rule, fontsize=9.5, va="top")
    draw_side(ax, SIDE)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    draw(parser.parse_args().out)


if __name__ == "__main__":
    main()
