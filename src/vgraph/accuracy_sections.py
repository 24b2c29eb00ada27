"""``vgraph bench accuracy``: error against frame time, a section per renderer (``--renderers``).

- curvature: the CurvatureRaycaster (vgraph.accuracy, vgraph.accuracy_report): accuracy.csv,
  accuracy.md, accuracy.png and the two figures;
- tetrahedra: ProjectedTetrahedra's integrations and visibility orders (vgraph.accuracy_tetra):
  tetrahedra.md, tetrahedra.png;
- bricked: the BrickedRayCaster's levels of detail and error budget (vgraph.accuracy_bricks):
  bricked.md, bricked.png.

Every section's options are checked (names, numbers, data files) before any section measures, so
a mistake in the last one does not cost the minutes of the first. --size and --repeat apply to
every section chosen; without them each section takes its own default (or --quick's).
"""

from __future__ import annotations

import sys
from pathlib import Path

from vgraph import accuracy_bricks, accuracy_report, accuracy_tetra
from vgraph.accuracy_common import BONSAI, DISK_MESH, POST_MESH
from vgraph.errors import VGraphError

RENDERERS = ("curvature", "tetrahedra", "bricked")


def renderers_of(args) -> tuple[str, ...]:
    chosen = tuple(getattr(args, "renderers", None) or RENDERERS)
    bad = [name for name in chosen if name not in RENDERERS]
    if bad:
        raise VGraphError(f"--renderers: unknown {', '.join(map(repr, bad))}; "
                          f"choose from {', '.join(RENDERERS)}")
    return tuple(name for name in RENDERERS if name in chosen)  # in the sections' order


def section_options(args, defaults: dict, quick: dict) -> dict:
    """A section's settings: the options given, else --quick's or the section's defaults."""
    base = quick if getattr(args, "quick", False) else defaults
    chosen = {}
    for key, default in base.items():
        value = getattr(args, key, None)
        chosen[key] = default if value is None else tuple(value) if isinstance(value, list) else value
    return chosen


def tetra_files(args) -> dict:
    return {"post": (Path(getattr(args, "post_mesh", None) or POST_MESH), "--post-mesh"),
            "disk": (Path(getattr(args, "disk_mesh", None) or DISK_MESH), "--disk-mesh")}


def plan(args) -> list[tuple[str, dict]]:
    """(renderer, its checked settings) of every section chosen; raises before any work."""
    sections = []
    for renderer in renderers_of(args):
        if renderer == "curvature":
            sections.append((renderer, accuracy_report.checked_options(args)))
        elif renderer == "tetrahedra":
            settings = section_options(args, accuracy_tetra.DEFAULTS, accuracy_tetra.QUICK)
            settings["files"] = tetra_files(args)
            accuracy_tetra.check_options(settings["meshes"], settings["integrations"], settings["orders"],
                                         settings["repeat"], settings["files"])
            sections.append((renderer, settings))
        else:
            settings = section_options(args, accuracy_bricks.DEFAULTS, accuracy_bricks.QUICK)
            settings["bonsai"] = Path(getattr(args, "bonsai", None) or BONSAI)
            accuracy_bricks.check_options(settings["volumes"], settings["repeat"], settings["brick"],
                                          settings["bonsai"])
            sections.append((renderer, settings))
    return sections


def measure_and_write(renderer: str, settings: dict, out: Path) -> list[Path]:
    if renderer == "curvature":
        return accuracy_report.measure_and_write(settings, out)
    if renderer == "tetrahedra":
        rows = accuracy_tetra.run(**settings)
        return accuracy_tetra.write(rows, out, settings["size"], settings["repeat"], settings["files"])
    rows = accuracy_bricks.run(**settings)
    return accuracy_bricks.write(rows, out, settings["size"], settings["repeat"], settings["brick"],
                                 settings["bonsai"])


def command(args) -> int:
    """Check every chosen section, then measure each, print its tables and write its files."""
    sections = plan(args)
    out = Path(args.out) if getattr(args, "out", None) else accuracy_report.DEFAULT_OUT
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for renderer, settings in sections:
        written += measure_and_write(renderer, settings, out)
    print("wrote " + ", ".join(map(str, written)), file=sys.stderr)
    return 0
