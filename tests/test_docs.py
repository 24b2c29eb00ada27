"""The examples in docs/ run: ```python blocks execute in order per page, and ```console lines
starting with `$ vgraph` run as commands, from a folder that holds the repository's networks/ and
the shared data sets as data/ (a page marked `<!-- needs the shared data sets -->` is skipped
where they are absent).
A block whose info string says `file=PATH` must appear verbatim in that file instead; a fragment
marked `not-run` (it needs surrounding code) is skipped."""

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from helpers.paths import DATA, REPO

BLOCK = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```", re.S | re.M)
PAGES = sorted((REPO / "docs").glob("*.md"))


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
        pytest.skip(f"{page.name} uses the shared data sets, not found at {DATA}")


@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p, "python")], ids=lambda p: p.name)
def test_python_examples_run(page, workdir):
    needs_data(page)
    namespace = {"__name__": "__doc_example__"}
    for info, code in blocks(page, "python"):
        if info.startswith("file="):
            assert code.strip() in (REPO / info[5:]).read_text(), f"{page.name}: block differs from {info[5:]}"
            continue
        if "not-run" in info:
            continue
        exec(compile(code, f"{page.name}", "exec"), namespace)


@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p, "console")], ids=lambda p: p.name)
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
            assert done.returncode == 0, f"{page.name}: {line}\n{done.stderr}"
