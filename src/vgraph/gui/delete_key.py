"""The Delete key inside an editor's plot: the window's Delete shortcut deletes the selected
processors, so a plot that removes its own selected point or primitive with Delete (or Backspace)
claims the key while it has the focus, and then gets it as a key press."""

from __future__ import annotations

from PySide6.QtCore import QEvent, Qt

DELETE_KEYS = (Qt.Key_Delete, Qt.Key_Backspace)


def is_delete_key(event) -> bool:
    """Whether a key event is Delete or Backspace."""
    return event.key() in DELETE_KEYS


class OwnsDeleteKey:
    """A QWidget mixin (listed before the Qt class) whose keyPressEvent gets Delete and Backspace
    instead of the window's shortcut."""

    def event(self, event):
        if event.type() == QEvent.ShortcutOverride and is_delete_key(event):
            event.accept()
            return True
        return super().event(event)
