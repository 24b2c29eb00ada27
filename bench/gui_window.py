"""A fresh main window for the bench's GUI pictures (make_gui_screenshots, make_mpr_screenshot,
make_picking_screenshot, make_slice_markups_screenshot, make_table_dock_screenshot): its own
settings file in a temporary folder, so the user's remembered layout is not used, laid out as a first
run on a screen of the given size (``layout.arrange``); and the command line those scripts share.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def fresh_window(size: tuple[int, int], network: Path | None = None, settings_values: dict | None = None,
                 recent: tuple[Path, ...] = ()):
    """Yield ``(app, window)``: shown at ``size``, with ``network`` opened and fitted in the view
    (if given), ``settings_values`` set before the window reads them and ``recent`` as its recent
    files (most recent first)."""
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QApplication

    from vgraph.gui.app import MainWindow

    app = QApplication.instance() or QApplication([sys.argv[0]])
    app.setApplicationName("vgraph")
    with tempfile.TemporaryDirectory() as folder:
        settings = QSettings(str(Path(folder) / "settings.ini"), QSettings.IniFormat)
        for key, value in (settings_values or {}).items():
            settings.setValue(key, value)
        window = MainWindow(settings)
        window.remember_layout = False
        for path in reversed(recent):
            window.workspace.add_recent_file(path)
        window.arrange(*size)
        window.show()
        if network is not None:
            window.workspace.open(network)
            window.view.fit_network()
        yield app, window


def screenshot_parser(doc: str, out: Path, size: str) -> argparse.ArgumentParser:
    """The options every screenshot script takes: ``--out`` (default ``out``) and ``--size`` WIDTHxHEIGHT
    (default ``size``); described by the first line of the script's ``doc``."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--out", type=Path, default=out)
    parser.add_argument("--size", default=size)
    return parser


def window_size(text: str) -> tuple[int, int]:
    """``"1920x1080"`` as ``(1920, 1080)``."""
    width, height = (int(v) for v in text.lower().split("x"))
    return width, height


def screenshot_main(doc: str, out: Path, size: str, shoot, argv=None) -> int:
    """The main() of a screenshot script with no options of its own: ``shoot(out, (width, height))``."""
    args = screenshot_parser(doc, out, size).parse_args(argv)
    shoot(args.out, window_size(args.size))
    return 0
