"""The examples in docs/ run: ```python blocks execute in order per page (docs/ and its folders), and ```console lines
starting with `$ vgraph` run as commands, from a folder that holds the repository's networks/ and
the shared data sets as data/ (a page marked `<!-- needs the shared data sets -->` is skipped
where they are absent).
A block whose info string says `file=PATH` must appear verbatim in that file instead; a fragment
marked `not-run` (it needs surrounding code) is skipped.
Every link between pages names a page that exists and, with a #fragment, a heading (or an
`<a id>`) on it; docs/README.md lists every page of the guide, the explanations and the reports."""

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from helpers.paths import DATA, REPO

BLOCK = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```", re.S | re.M)
DOCS = REPO / "docs"
PAGES = sorted(DOCS.rglob("*.md"))
LINK = re.compile(r"\]\(([^)\s]+)\)")
SECTIONS = ("guide", "explanations", "reports")   # the index lists these; reference/ has its own


def blocks(page: Path, language: str):
    return [(info.strip(), body) for lang, info, body in BLOCK.findall(page.read_text()) if lang == language]


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    (tmp_path / "networks").symlink_to(REPO / "networks")
    if DATA.is_dir():  # pages on real data name its files as data/...
        (tmp_path / "data").symlink_to(DATA)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def needs_data(page: Path) -> None:
    if "<!-- needs the shared data sets -->" in page.read_text() and not DATA.is_dir():
        pytest.skip(f"{page_id(page)} uses the shared data sets, not found at {DATA}")


def page_id(page: Path) -> str:
    return page.relative_to(DOCS).as_posix()


def anchors(page: Path) -> set[str]:
    from vgraph.reference_docs import page_anchors
    return page_anchors(page) | set(re.findall(r'<a id="([^"]+)"></a>', page.read_text(encoding="utf-8")))


def prose(page: Path) -> str:
    """The page without its code blocks (a link inside code is an example, not a link)."""
    return BLOCK.sub("", page.read_text(encoding="utf-8"))


def test_links_between_pages_name_existing_pages_and_headings():
    broken = []
    for page in PAGES:
        for link in LINK.findall(prose(page)):
            path, _, fragment = link.partition("#")
            if re.match(r"[a-z]+:", link) or not (path.endswith(".md") or (not path and fragment)):
                continue
            target = (page.parent / path).resolve() if path else page
            if not target.is_file():
                broken.append(f"{page_id(page)}: {link}: no such page")
            elif fragment and fragment not in anchors(target):
                broken.append(f"{page_id(page)}: {link}: no such heading")
    assert not broken, "\n".join(broken)


def test_the_index_lists_every_page():
    index = (DOCS / "README.md").read_text(encoding="utf-8")
    listed = {(DOCS / path).resolve() for path in LINK.findall(index)}
    pages = [page for section in SECTIONS for page in (DOCS / section).rglob("*.md")]
    assert len(pages) > 20
    missing = [page_id(page) for page in pages if page.resolve() not in listed]
    assert not missing, f"docs/README.md does not list {missing}"
    assert (DOCS / "reference" / "index.md").resolve() in listed


@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p, "python")], ids=page_id)
def test_python_examples_run(page, workdir):
    needs_data(page)
    namespace = {"__name__": "__doc_example__"}
    for info, code in blocks(page, "python"):
        if info.startswith("file="):
            assert code.strip() in (REPO / info[5:]).read_text(), f"{page_id(page)}: block differs from {info[5:]}"
            continue
        if "not-run" in info:
            continue
        exec(compile(code, page_id(page), "exec"), namespace)


@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p, "console")], ids=page_id)
def test_console_examples_run(page, workdir):
    needs_data(page)
    for info, body in blocks(page, "console"):
        if "not-run" in info:
            continue
        for line in body.splitlines():
            if not line.startswith("$ vgraph"):
                continue
            args = shlex.split(line[2:])[1:]
            done = subprocess.run([sys.executable, "-m", "vgraph", *args], capture_output=True, text=True,
                                  timeout=600)
            assert done.returncode == 0, f"{page_id(page)}: {line}\n{done.stderr}"
