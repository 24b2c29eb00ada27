"""Fixtures shared by the tests. Helpers that are not fixtures live in the ``helpers`` package.

The toy processors (helpers.toy_processors) are registered here, once, so every test can add
them by type name; the render process imports them by module name like any plug-in.

bench/ goes on sys.path so the tests import the tools they share with the bench by module name
(``from fuzz_cases import ...``, ``from scripted_user import ScriptedUser``; docs/explanations/architecture.md).
"""

import os
import sys
from pathlib import Path

import pytest

import vgraph
from helpers import toy_processors
from helpers.paths import BENCH, DATA

sys.path.append(str(BENCH))  # after the installed packages: a bench script never shadows one

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")  # read when pytest-qt creates the QApplication

for _cls in toy_processors.ALL:
    vgraph.register(_cls)


@pytest.fixture
def data_dir():
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    return DATA


@pytest.fixture
def gl():
    from vgraph.gl_context import get_context
    return get_context()


@pytest.fixture(scope="session")
def renderer():
    """One render process for all GUI tests (starting one takes a second or two)."""
    from vgraph.live.render_process import RenderProcess
    process = RenderProcess()
    yield process
    process.stop()


@pytest.fixture
def window(qtbot, tmp_path, renderer):
    """A shown main window with its own settings file (recent files do not touch the user's)."""
    from PySide6.QtCore import QSettings
    from vgraph.gui.app import MainWindow
    settings = QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat)
    main = MainWindow(settings, renderer)
    main.show()
    qtbot.waitExposed(main)
    yield main
    main.workspace.undo_stack.setClean()  # no unsaved-changes prompt on closing
    main.close()                           # closeEvent detaches the views from the network
    main.deleteLater()


@pytest.fixture
def jobs(window, monkeypatch):
    """Every job the window submits from now on (the shared render process still gets them);
    the window's first job (its empty network, sent by a timer) is done before recording starts,
    so that the tests do not depend on whether that timer fired yet."""
    window.evaluation.run(wait=True)
    renderer, submitted = window.evaluation.renderer, []
    submit = renderer.submit
    monkeypatch.setattr(renderer, "submit", lambda job: (submitted.append(job), submit(job))[1])
    return submitted


@pytest.fixture
def test_shader_dir(monkeypatch):
    """tests/shaders on the shader search path for one test only: adding it at import time changed
    the path for every test collected after."""
    from vgraph.gl import shaders
    directory = Path(__file__).parent / "shaders"
    monkeypatch.setattr(shaders, "_extra_dirs", list(shaders._extra_dirs))  # restored afterwards
    shaders.add_shader_dir(directory)
    return directory
