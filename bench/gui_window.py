"""A fresh main window for the bench's GUI pictures (make_gui_screenshots, make_mpr_screenshot,
make_picking_screenshot): its own settings file in a temporary folder, so the user's remembered
layout is not used, laid out as a first run on a screen of the given size (``layout.arrange``).
"""

from __future__ import annotations

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
