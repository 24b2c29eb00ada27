"""The processor reference: one Markdown page per built-in processor, written from its declaration
(ports with their types, properties with defaults, ranges, choices and docs), and an index by
category. Run from the repository root after changing a declaration::

    python -m vgraph.reference_docs            # rewrites docs/reference/
    python -m vgraph.reference_docs FOLDER     # writes the pages into FOLDER instead

Conventions:
- A page holds the declaration and two small tables of this module: the picture of docs/images
  that shows the processor (``PICTURES``) and the sections of the guide and explanation pages
  that explain it (``EXPLAINED_IN``). Nothing else is read, so a page changes exactly when its processor's
  declaration or these tables do; tests/test_reference_docs.py regenerates the pages and compares
  them with the committed ones, and checks that every picture and section named here exists.
- Built-in processors only (``vgraph.processors``): a plug-in installed beside vgraph would
  otherwise change the committed pages. ``vgraph list`` shows plug-ins too, in the same words
  (vgraph.property_text).
- The folder's top level belongs to this generator: pages of processors that no longer exist are
  removed. The hand-written reference pages (the command line, the network format, the implicit
  functions) live in its subfolder ``general/`` (``GENERAL_PAGES``), which the index links.
  Every page is written atomically (vgraph.atomic).
"""

from __future__ import annotations

import json
import re
import sys
from inspect import cleandoc
from pathlib import Path

from vgraph.atomic import make_folders, write_text_atomic
from vgraph.errors import VGraphError
from vgraph.processor import Processor
from vgraph.property_text import default_text, kind_text
from vgraph.registry import registry

BUILTIN_MODULE = "vgraph.processors."
INDEX = "index.md"
COMMAND = "python -m vgraph.reference_docs"
# The hand-written reference pages beside the generated ones (relative to docs/reference/).
GENERAL_PAGES: tuple[tuple[str, str], ...] = (
    ("general/cli.md", "the `vgraph` command: every subcommand and option"),
    ("general/network-format.md", "the `.json` network format, its errors and migrations"),
    ("general/functions.md", "FunctionSelector's implicit functions and their Python API"),
)

# The existing picture of docs/images that shows what the processor makes, with its caption.
PICTURES: dict[str, tuple[str, str]] = {
    "EntryExitPoints": ("rendering_entry_exit.png", "Entry and exit points of a box"),
    "RayCaster": ("rendering_compositing.png", "The compositing modes"),
    "CurvatureRaycaster": ("curvature_measures.png", "Curvature measures of the torus"),
    "CurvatureVolumeRaycaster": ("curvature_volume.png", "The torus's distance field coloured by curvature"),
    "MultiVolumeRayCaster": ("exploring_channels_blends.png", "The three blend modes of two channels"),
    "LabelRayCaster": ("exploring_labels_boundaries.png",
                       "The RayCaster against the LabelRayCaster on two touching label boxes"),
    "LightVolume": ("shadows_bonsai.png", "The bonsai without and with shadows, and a slice of its light volume"),
    "SliceViewer": ("exploring_slice_display.png",
                    "An axial slice of the head in radiological (default) and neurological display"),
    # networks/head_skin_mesh_bone_volume.json: these four make that picture together
    **dict.fromkeys(("IsoSurfaceExtractor", "GeometryRenderer", "GeometryEntryExit", "ImageCompositor"),
                    ("exploring_surfaces.png", "CT head: skin as a mesh, bone as volume rendering")),
    **dict.fromkeys(("ImageBlur", "EdgeDetect", "DepthDarkening"),
                    ("image_filters.png", "The ray-cast head, ImageBlur, EdgeDetect, DepthDarkening and both")),
    # bench/make_image_processor_images.py: the issue-35 image processors and the Histogram together
    **dict.fromkeys(("ImageGamma", "Background", "TextOverlay", "ImageThreshold", "ImageMix", "Histogram"),
                    ("image_processors.png", "Background, ImageGamma and TextOverlay; ImageThreshold; ImageMix; "
                                             "the Histogram")),
    "LineProfile": ("measuring_profile.png", "A line through the engine CT and its profile"),  # bench/make_measuring_images.py
    "Markups": ("markups_head.png", "A ruler, an angle and a closed curve over the CT head"),  # bench/make_markups_image.py
    "ProjectedTetrahedra": ("tetra_modes.png",
                            "Averaged and pre-integrated projection against the exact reference"),
    "VolumeToTetMesh": ("tetra_culling.png", "The culled bonsai as tetrahedra beside the RayCaster"),
    # bench/make_reference_images.py
    "BrickedRayCaster": ("bricked_levels.png", "The torus drawn at levels of detail 0, 1 and 2"),
    "SweepPlaneRenderer": ("sweep_plane.png", "The torus by RZSweep beside the RayCaster"),
}

# The sections of the guide and explanation pages (relative to docs/) that explain the processor.
EXPLAINED_IN: dict[str, tuple[str, ...]] = {
    "Background": ("guide/image-filters.md#background",),
    "BrickedRayCaster": ("explanations/bricked-ray-casting.md", "guide/large-data.md#rendering"),
    "ColorBar": ("guide/outputs.md#colorbar", "guide/own-data.md#a-colour-bar"),
    "ConnectedComponents": ("guide/volume-filters.md#connectedcomponents",),
    "CubicSplineProcessor": ("explanations/curvature.md#which-volume-goes-in", "explanations/tricubic.md"),
    "CurvatureRaycaster": ("explanations/curvature.md#curvatureraycaster",),
    "CurvatureVolumeRaycaster": ("explanations/curvature.md#curvaturevolumeraycaster",),
    "DepthDarkening": ("guide/image-filters.md#depthdarkening",),
    "EdgeDetect": ("guide/image-filters.md#edgedetect",),
    "EntryExitPoints": ("explanations/ray-casting.md#entryexitpoints", "guide/clipping.md#clipping-planes-and-the-crop-box"),
    "FunctionSelector": ("reference/general/functions.md",),
    "GeometryEntryExit": ("guide/surfaces.md#geometryentryexit-and-imagecompositor",),
    "GeometryRenderer": ("guide/surfaces.md#geometryrenderer",),
    "GradientMagnitude": ("guide/volume-filters.md#gradientmagnitude",),
    "Grayscale": ("guide/scripting.md",),
    "Histogram": ("guide/statistics.md#histogram",),
    "ImageCompositor": ("guide/surfaces.md#geometryentryexit-and-imagecompositor",),
    "ImageBlur": ("guide/image-filters.md#imageblur",),
    "ImageGamma": ("guide/image-filters.md#imagegamma",),
    "ImageMix": ("guide/image-filters.md#imagemix",),
    "ImageSource": ("guide/scripting.md", "guide/own-data.md#a-single-slice"),
    "ImageThreshold": ("guide/image-filters.md#imagethreshold",),
    "ImageWriter": ("reports/reliability.md",),
    "IsoSurfaceExtractor": ("guide/surfaces.md#isosurfaceextractor",),
    "LabelRayCaster": ("guide/labels.md#label-volumes", "guide/own-data.md#label-volumes"),
    "LightVolume": ("guide/shadows.md",),
    "LineProfile": ("guide/measuring.md#lineprofile", "guide/measuring.md#tables"),
    "Markups": ("guide/measuring.md#markups", "guide/measuring.md#tables"),
    "MeshSource": ("explanations/tetrahedra.md#meshes-and-meshsource", "guide/own-data.md#meshes"),
    "MultiVolumeRayCaster": ("guide/several-volumes.md#several-volumes-in-one-picture",),
    "ProjectedTetrahedra": ("explanations/tetrahedra-renderer.md", "explanations/tetrahedra.md#projectedtetrahedra"),
    "RegionStatistics": ("guide/measuring.md#regionstatistics", "guide/measuring.md#tables"),
    "RayCaster": ("explanations/ray-casting.md#raycaster", "explanations/bricked-ray-casting.md#what-differs-from-the-raycaster"),
    "SliceViewer": ("guide/slices.md#slices-and-the-multi-planar-layout", "guide/own-data.md#a-single-slice"),
    "SurfaceSource": ("guide/surfaces.md#surfacesource",),
    "TextOverlay": ("guide/image-filters.md#textoverlay",),
    "VolumeInfo": ("guide/statistics.md#volumeinfo",),
    "VolumeMask": ("guide/volume-filters.md#volumemask",),
    "VolumeMath": ("guide/volume-filters.md#volumemath",),
    "VolumeMorphology": ("guide/volume-filters.md#volumemorphology",),
    "VolumeSource": ("guide/volumes.md#reading-volumes", "guide/volumes.md#volume-processors", "guide/own-data.md"),
    "VolumeToTetMesh": ("explanations/tetrahedra.md#volumetotetmesh",),
    "VolumeWriter": ("guide/volumes.md#writing-volumes",),
}


def builtin_processors() -> list[type[Processor]]:
    """The processor types of ``vgraph.processors``, by name."""
    return [cls for cls in registry.all() if cls.__module__.startswith(BUILTIN_MODULE)]


def reference_pages() -> dict[str, str]:
    """File name -> Markdown text of every page: one per built-in processor, and the index."""
    types = builtin_processors()
    pages = {f"{cls.type_name}.md": processor_page(cls) for cls in types}
    pages[INDEX] = index_page(types)
    return pages


def write_reference(folder: Path) -> list[str]:
    """Write the pages into ``folder`` (made if missing), each atomically, and remove the pages of
    processors that no longer exist. Returns the names written."""
    pages = reference_pages()
    make_folders(folder)
    for name, text in pages.items():
        write_text_atomic(folder / name, text)
    for stale in folder.glob("*.md"):
        if stale.name not in pages:
            stale.unlink()
    return sorted(pages)


# --- pages ----------------------------------------------------------------------------------------
def processor_page(cls: type[Processor]) -> str:
    lines = [f"# {cls.type_name}", "", *_doc_paragraphs(cls), "",
             f"Category: {cls.category} · module `{cls.__module__}` · [all processors]({INDEX})", ""]
    if cls.type_name in PICTURES:
        image, caption = PICTURES[cls.type_name]
        lines += [f"![{caption}](../images/{image})", ""]
    if cls.type_name in EXPLAINED_IN:
        links = ", ".join(f"[{_link_text(target)}](../{target})" for target in EXPLAINED_IN[cls.type_name])
        lines += [f"Explained in: {links}.", ""]
    lines += _ports_section("Inports", cls.inports) + _ports_section("Outports", cls.outports)
    lines += _properties_section(cls)
    return "\n".join(lines).rstrip() + "\n"


def index_page(types: list[type[Processor]]) -> str:
    lines = ["# Processor reference", "",
             "One page per built-in processor: its ports with their data types, its properties with "
             "defaults, ranges or choices and what they do, and where the guide and explanation pages explain it. "
             f"The pages are written from the processors' declarations by `{COMMAND}` (run from the "
             "repository root); do not edit them by hand. `vgraph list` prints the same in the "
             "terminal, plug-ins included.", "",
             "Also in the reference:", ""]
    lines += [f"- [{page.split('/')[-1]}]({page}): {what}" for page, what in GENERAL_PAGES]
    lines.append("")
    for category in sorted({cls.category for cls in types}):
        lines += [f"## {category}", "", "| Processor | What it does |", "|---|---|"]
        lines += [f"| [{cls.type_name}]({cls.type_name}.md) | {_cell(_summary(cls))} |"
                  for cls in types if cls.category == category]
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def _summary(cls: type[Processor]) -> str:
    """The docstring's first paragraph: ``description`` is its first line only, which a docstring
    wrapped over two lines leaves unfinished."""
    paragraph = "\n".join(_doc_paragraphs(cls)).split("\n\n")[0]
    return " ".join(paragraph.split())


def _doc_paragraphs(cls: type[Processor]) -> list[str]:
    """The class docstring (its own, not a base's) as written, else the description."""
    doc = cls.__dict__.get("__doc__")
    return cleandoc(doc).splitlines() if doc else [cls.description or "(no description)"]


def _ports_section(title: str, ports) -> list[str]:
    if not ports:
        return []
    lines = [f"## {title}", "", "| Port | Data type | Notes | Description |", "|---|---|---|---|"]
    for port in ports:
        lines.append(f"| `{port.name}` | {port.type_name} | {_port_flags(port)} | {_cell(port.description)} |")
    return lines + [""]


def _port_flags(port) -> str:
    flags = [flag for flag in ("optional", "multiple", "on_demand") if getattr(port, flag, False)]
    return ", ".join(flag.replace("_", " ") for flag in flags)


def _properties_section(cls: type[Processor]) -> list[str]:
    if not cls.properties:
        return ["## Properties", "", "None.", ""]
    lines = ["## Properties", "", "| Property | Kind | Default | Description |", "|---|---|---|---|"]
    for prop in cls.properties.values():
        lines.append(f"| `{prop.name}` | {_cell(kind_text(prop))} | {_code(_default(prop))} | "
                     f"{_cell(prop.doc)} |")
    return lines + [""]


def _default(prop) -> str:
    """As ``vgraph list`` says it, except a transfer function, a label table and markups: in full, as JSON
    (the page has room for them, where the terminal cuts them short or refers to ``--json``)."""
    if prop.kind in ("transfer_function", "label_table", "markups"):
        return json.dumps(prop.to_json(prop.default))
    return default_text(prop)


def _link_text(target: str) -> str:
    """``explanations/ray-casting.md#raycaster`` -> ``ray-casting.md, raycaster``: the page's
    file name and the section."""
    page, _, section = target.partition("#")
    page = page.rsplit("/", 1)[-1]
    return f"{page}, {section.replace('-', ' ')}" if section else page


def _cell(text: str) -> str:
    """Text for one cell of a Markdown table: one line, pipes escaped."""
    return " ".join(text.split()).replace("|", "\\|")


def _code(text: str) -> str:
    return f"`{_cell(text)}`" if "`" not in text else _cell(text)


# --- headings, for checking the links of EXPLAINED_IN ---------------------------------------------
def heading_anchor(heading: str) -> str:
    """The anchor GitHub gives a heading: lower case, punctuation dropped, spaces as hyphens."""
    text = heading.strip().lower().replace("`", "")
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def page_anchors(page: Path) -> set[str]:
    """The anchors of a Markdown page's headings (outside code blocks)."""
    anchors, in_code = set(), False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            in_code = not in_code
        elif not in_code and re.match(r"#{1,6} ", line):
            anchors.add(heading_anchor(line.lstrip("#")))
    return anchors


def main(argv: list[str]) -> int:
    if len(argv) > 1:
        print(f"usage: {COMMAND} [FOLDER]", file=sys.stderr)
        return 2
    if argv:
        folder = Path(argv[0])
    elif Path("docs").is_dir():
        folder = Path("docs") / "reference"
    else:
        print(f"{COMMAND}: no docs/ folder here; run it from the repository root or name the folder",
              file=sys.stderr)
        return 2
    try:
        names = write_reference(folder)
    except VGraphError as error:
        print(f"{COMMAND}: {error}", file=sys.stderr)
        return 2
    print(f"wrote {len(names)} pages to {folder}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
