"""The log panel: what happened (files opened and saved, evaluations) and every error, with time.

``entries`` keeps (level, message) pairs so tests and other views can read the log without
parsing text. Errors are shown in red. Nothing here raises: the log is where failures go to be seen.
"""

from __future__ import annotations

import html
import time

from PySide6.QtWidgets import QPlainTextEdit

LEVEL_COLORS = {"info": "#374151", "warning": "#b45309", "error": "#b91c1c"}
MAX_BLOCKS = 5000


class LogPanel(QPlainTextEdit):
    def __init__(self, parent=None):
        super().__init__(parent)
        self.setReadOnly(True)
        self.setMaximumBlockCount(MAX_BLOCKS)
        self.entries: list[tuple[str, str]] = []

    def add(self, level: str, message: str) -> None:
        self.entries.append((level, message))
        del self.entries[:-MAX_BLOCKS]
        stamp = time.strftime("%H:%M:%S")
        color = LEVEL_COLORS.get(level, LEVEL_COLORS["info"])
        text = html.escape(message).replace("\n", "<br>")
        self.appendHtml(f'<span style="color:{color}">{stamp} {level}: {text}</span>')

    def info(self, message: str) -> None:
        self.add("info", message)

    def warning(self, message: str) -> None:
        self.add("warning", message)

    def error(self, message: str) -> None:
        self.add("error", message)

    def messages(self, level: str | None = None) -> list[str]:
        return [m for lv, m in self.entries if level is None or lv == level]
