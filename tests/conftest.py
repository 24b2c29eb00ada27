"""Shared test fixtures: where the repository and the shared data sets are, and toy processors."""

import os
from pathlib import Path

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data"


@pytest.fixture
def data_dir() -> Path:
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    return DATA


@pytest.fixture
def gl():
    from vgraph.gl.context import get_context
    return get_context()


@pytest.fixture(scope="session")
def renderer():
    """One render process for all GUI tests (starting one takes a second or two)."""
    from vgraph.gui.render_process import RenderProcess
    process = RenderProcess()
    yield process
    process.stop()
