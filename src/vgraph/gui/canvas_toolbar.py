"""The toolbar above each canvas: fit to data, named views, save the image, and the overlays.

``CanvasPane`` is what a canvas dock shows: a compact ``CanvasToolbar`` above its ``CanvasView``.

Conventions:
- Every action acts on its own canvas (on the camera ``camera_property_for`` finds, as the mouse
  does) and is one undo step.
- Shortcuts work while the canvas (or its toolbar) has the keyboard focus (click into the canvas),
  so two canvases do not fight over a key: F fits, the digits turn to named views as on a
  numeric keypad (1 front, 3 right, 7 top; with Ctrl the opposite side), 5 iso; A, B and S switch
  the axes, the box and the slices, M places markups (markup_placing.py; a mode, not
  remembered). Tooltips name them; Help > Keyboard Shortcuts lists them.
- Save Image (and File > Export Image) saves only a complete frame: a coarse one (drawn while a
  drag lasts, or while a bricked volume still reads, "refining...") is not what ``vgraph run``
  writes, so the user is told to wait instead (``save_complete_frame``).
- Overlay switches are remembered per canvas id in the window's QSettings
  (``canvas/<id>/axes``, ``canvas/<id>/box``, ``canvas/<id>/slices``): the triad and the slices
  are on and the box off the first time. "Slices" draws the planes of the network's
  SliceViewers in a 3D canvas (overlays.py), and the crosshair lines, outline and readouts in a
  slice canvas (slice_overlay.py), so it shows nothing in a network without them.
"""

from __future__ import annotations

from PySide6.QtCore import QSettings, QSize, Qt
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import QMenu, QStyle, QToolBar, QToolButton, QVBoxLayout, QWidget

from vgraph.gui.canvas_view import CanvasView

# name -> (menu text, shortcut); the order of the menu.
VIEW_ACTIONS = {
    "front": ("Front (anterior)", "1"),
    "back": ("Back (posterior)", "Ctrl+1"),
    "left": ("Left", "Ctrl+3"),
    "right": ("Right", "3"),
    "top": ("Top (superior)", "7"),
    "bottom": ("Bottom (inferior)", "Ctrl+7"),
    "iso": ("Iso", "5"),
}
FIT_KEY, AXES_KEY, BOX_KEY, SLICES_KEY, PLACE_KEY = "F", "A", "B", "S", "M"
OVERLAY_DEFAULTS = {"axes": True, "box": False, "slices": True}
STILL_REFINING = "the frame is still refining: save it when 'refining...' is gone"


def save_complete_frame(view: CanvasView, path=None):
    """``view.save_image(path)`` if its frame is complete (final); otherwise say why not."""
    if view.frame() is not None and not view.is_final:
        view.set_message(STILL_REFINING)
        view.problem.emit(STILL_REFINING)
        return None
    return view.save_image(path)


def overlay_setting(canvas_id: str, overlay: str) -> str:
    return f"canvas/{canvas_id}/{overlay}"


class CanvasToolbar(QToolBar):
    def __init__(self, view: CanvasView, settings: QSettings | None = None, parent: QWidget | None = None):
        super().__init__(f"{view.canvas_id} tools", parent)
        self.view, self.settings = view, settings
        self.setIconSize(QSize(16, 16))
        self.setToolButtonStyle(Qt.ToolButtonTextOnly)
        self.fit_action = self._add("Fit", "Fit to data: frame the data again, keeping the direction",
                                    FIT_KEY, view.fit_to_data)
        self.view_actions = {name: self._make(text, f"Look at the data from the {name}", key,
                                              lambda *_, name=name: view.set_view(name))
                             for name, (text, key) in VIEW_ACTIONS.items()}
        self.views_button = self._menu_button("View", "Named views (fit the data)",
                                              self.view_actions.values())
        self.addSeparator()
        self.axes_action = self._add("Axes", "Show the orientation axes (x red, y green, z blue)",
                                     AXES_KEY, view.set_axes_visible, checkable=True)
        self.box_action = self._add("Box", "Show the data's bounding box", BOX_KEY,
                                    view.set_box_visible, checkable=True)
        self.slices_action = self._add("Slices", "Show the SliceViewers' planes: outlines in a 3D "
                                       "view, crosshairs and readouts in a slice view (axial red, "
                                       "sagittal yellow, coronal green)", SLICES_KEY, view.set_slices_visible,
                                       checkable=True)
        self.addSeparator()
        self.place_action = self._add("Place", "Place markups: a left click adds a point of the kind chosen in "
                                      "the Markups processor's editor, on the picked surface (in a slice, on "
                                      "its plane); a drawn point is dragged in any mode", PLACE_KEY,
                                      view.set_placing, checkable=True)
        self.addSeparator()
        self.save_action = self._add("Save Image...", "Save the frame as a PNG, as `vgraph run` writes "
                                     "it (no overlays); File > Export Image (Ctrl+E) does the same",
                                     None, lambda: save_complete_frame(view))
        self.save_action.setIcon(self.style().standardIcon(QStyle.SP_DialogSaveButton))
        self.widgetForAction(self.save_action).setToolButtonStyle(Qt.ToolButtonIconOnly)
        self._restore_overlays()
        for name, action in self._overlay_actions().items():
            action.toggled.connect(lambda on, name=name: self._remember(name, on))

    # --- building -------------------------------------------------------------------------------
    def _make(self, text: str, tip: str, key: str | None, slot, checkable: bool = False) -> QAction:
        action = QAction(text, self)
        action.setCheckable(checkable)
        if key:
            action.setShortcut(QKeySequence(key))
            # Only while this canvas has the focus: each canvas has the same keys.
            action.setShortcutContext(Qt.WidgetWithChildrenShortcut)
            tip = f"{tip} ({QKeySequence(key).toString(QKeySequence.NativeText)})"
        action.setToolTip(tip)
        if checkable:
            action.toggled.connect(slot)
        else:
            action.triggered.connect(lambda *_: slot())
        return action

    def _add(self, text, tip, key, slot, checkable=False) -> QAction:
        action = self._make(text, tip, key, slot, checkable)
        self.addAction(action)
        return action

    def _menu_button(self, text: str, tip: str, actions) -> QToolButton:
        button = QToolButton(self)
        button.setText(text)
        button.setToolTip(tip)
        button.setPopupMode(QToolButton.InstantPopup)
        menu = QMenu(button)
        menu.addActions(list(actions))
        button.setMenu(menu)
        self.addWidget(button)
        return button

    def keyboard_actions(self) -> list[QAction]:
        """The actions with shortcuts, to be added to the pane so the keys work in the view too."""
        return [self.fit_action, *self.view_actions.values(), *self._overlay_actions().values(),
                self.place_action]

    # --- overlays remembered --------------------------------------------------------------------
    def _overlay_actions(self) -> dict[str, QAction]:
        return {"axes": self.axes_action, "box": self.box_action, "slices": self.slices_action}

    def _restore_overlays(self) -> None:
        setters = {"axes": self.view.set_axes_visible, "box": self.view.set_box_visible,
                   "slices": self.view.set_slices_visible}
        for name, action in self._overlay_actions().items():
            on = OVERLAY_DEFAULTS[name]
            if self.settings is not None:
                on = self.settings.value(overlay_setting(self.view.canvas_id, name), on, type=bool)
            action.setChecked(on)
            setters[name](on)  # setChecked emits toggled only on a change: tell the view either way

    def _remember(self, name: str, on: bool) -> None:
        if self.settings is not None:
            self.settings.setValue(overlay_setting(self.view.canvas_id, name), bool(on))


class CanvasPane(QWidget):
    """A canvas dock's widget: the toolbar above the view."""

    def __init__(self, view: CanvasView, settings: QSettings | None = None, parent: QWidget | None = None):
        super().__init__(parent)
        self.view = view
        self.toolbar = CanvasToolbar(view, settings, self)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(0)
        layout.addWidget(self.toolbar)
        layout.addWidget(view, 1)
        self.addActions(self.toolbar.keyboard_actions())
