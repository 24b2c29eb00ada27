"""The processor reference (docs/reference/, written by vgraph.reference_docs) is current: written
again from the declarations it equals the committed pages, it covers every built-in processor, and
every picture and essay section it names exists."""

import re

from vgraph.reference_docs import (COMMAND, EXPLAINED_IN, INDEX, PICTURES, builtin_processors, heading_anchor, main,
                                   page_anchors, processor_page, write_reference)
from vgraph.registry import registry

from helpers.paths import REPO

DOCS = REPO / "docs"
REFERENCE = DOCS / "reference"
REGENERATE = f"run `{COMMAND}` in the repository root and commit docs/reference/"


def read_pages(folder):
    return {page.name: page.read_text(encoding="utf-8") for page in folder.glob("*.md")}


def test_the_committed_pages_equal_the_declarations(tmp_path):
    write_reference(tmp_path)
    generated, committed = read_pages(tmp_path), read_pages(REFERENCE)
    missing, extra = sorted(generated.keys() - committed.keys()), sorted(committed.keys() - generated.keys())
    assert not missing and not extra, f"pages missing: {missing}, pages of no processor: {extra}; {REGENERATE}"
    stale = sorted(name for name in generated if generated[name] != committed[name])
    assert not stale, f"out of date: {', '.join(stale)}; {REGENERATE}"


def test_every_builtin_processor_has_a_page_listed_in_the_index():
    types = builtin_processors()
    assert len(types) >= 20 and {"RayCaster", "VolumeSource", "Canvas"} <= {cls.type_name for cls in types}
    index = (REFERENCE / INDEX).read_text(encoding="utf-8")
    for cls in types:
        assert (REFERENCE / f"{cls.type_name}.md").is_file(), cls.type_name
        assert f"[{cls.type_name}]({cls.type_name}.md)" in index
        assert f"## {cls.category}\n" in index


def test_a_page_gives_ports_properties_defaults_ranges_and_docs():
    page = (REFERENCE / "RayCaster.md").read_text(encoding="utf-8")
    assert page.startswith("# RayCaster\n")
    assert "| `volume` | Volume |" in page and "| `entry` | Image |" in page
    assert "| `depth` | Image | on demand |" in page
    assert "| `compositing` | option: dvr\\|mip\\|iso\\|first_hit\\|xray | `'dvr'` | dvr, mip, iso" in page
    declared = registry.get("RayCaster").properties["sampling_rate"]   # as `vgraph list` says it
    assert f"| `sampling_rate` | float {declared.min:g}..{declared.max:g} | `{declared.default!r}` |" in page
    assert "![The compositing modes](../images/rendering_compositing.png)" in page
    assert "[ray-casting.md, raycaster](../explanations/ray-casting.md#raycaster)" in page


def test_a_processor_without_properties_or_docs_still_gets_a_page():
    from vgraph import Inport, Processor
    from vgraph.image import Image

    class Sink(Processor):
        inports = [Inport("image", Image, "what is shown", optional=True)]

        def process(self, image):
            return None

    page = processor_page(Sink)
    assert page.startswith("# Sink\n\n(no description)\n")
    assert "| `image` | Image | optional | what is shown |" in page
    assert "## Properties\n\nNone.\n" in page and "## Outports" not in page


def test_pictures_and_sections_named_exist():
    names = {cls.type_name for cls in builtin_processors()}
    assert set(PICTURES) <= names and set(EXPLAINED_IN) <= names
    for image, _ in PICTURES.values():
        assert (DOCS / "images" / image).is_file(), image
    for targets in EXPLAINED_IN.values():
        for target in targets:
            page, _, anchor = target.partition("#")
            assert (DOCS / page).is_file(), target
            assert not anchor or anchor in page_anchors(DOCS / page), f"{target}: no such heading"


def test_heading_anchors_are_githubs():
    assert heading_anchor(" GeometryEntryExit and ImageCompositor") == "geometryentryexit-and-imagecompositor"
    assert heading_anchor(" `vgraph animate`") == "vgraph-animate"
    assert heading_anchor(" Volumes: data, files and errors") == "volumes-data-files-and-errors"


def test_writing_replaces_old_pages_and_removes_those_of_no_processor(tmp_path):
    (tmp_path / "Gone.md").write_text("# Gone\n")
    (tmp_path / "RayCaster.md").write_text("# old\n")
    (tmp_path / "notes.txt").write_text("kept")
    names = write_reference(tmp_path)
    assert "Gone.md" not in names and not (tmp_path / "Gone.md").exists()
    assert (tmp_path / "RayCaster.md").read_text().startswith("# RayCaster\n")
    assert (tmp_path / "notes.txt").read_text() == "kept"
    assert not list(tmp_path.glob(".*"))   # no temporary files left behind


def test_links_into_and_out_of_the_reference_name_existing_pages():
    """The guide and explanation pages link a processor's reference page where they explain its
    properties (at least ray-casting.md's RayCaster section); those links and the reference's own
    resolve, the index's links to the hand-written reference pages (reference/general/) included."""
    link = re.compile(r"\]\(([^)#\s]+\.md)(?:#[^)]*)?\)")
    essays = [page for page in DOCS.rglob("*.md") if page.parent != REFERENCE]
    into = [(page, target) for page in essays for target in link.findall(page.read_text(encoding="utf-8"))
            if (page.parent / target).resolve().parent == REFERENCE.resolve()]
    assert ("ray-casting.md", "../reference/RayCaster.md") in {(page.name, target) for page, target in into}
    out_of = [(page, target) for page in REFERENCE.glob("*.md") for target in link.findall(page.read_text(encoding="utf-8"))]
    assert {f"general/{name}" for name in ("cli.md", "network-format.md", "functions.md")} <= {
        target for page, target in out_of if page.name == INDEX}
    assert len(out_of) > len(builtin_processors())
    for page, target in into + out_of:
        assert (page.parent / target).is_file(), f"{page.name} links {target}, which does not exist"


def test_the_command_writes_into_docs_reference_or_says_where_to_run_it(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main([]) == 2
    assert "run it from the repository root or name the folder" in capsys.readouterr().err
    (tmp_path / "docs").mkdir()
    assert main([]) == 0
    assert (tmp_path / "docs" / "reference" / "RayCaster.md").read_text() == (REFERENCE / "RayCaster.md").read_text()
    assert main(["a", "b"]) == 2 and "usage:" in capsys.readouterr().err
