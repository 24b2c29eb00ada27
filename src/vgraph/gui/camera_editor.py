"""The camera editor: projection, position, focus, up, field of view, near and far planes, fit
to data, and a Reset to the declared default.

Conventions:
- Typing a position or focus stores the camera (it stops fitting the data).
- A plane at 0 is "auto" (None): the renderer chooses planes enclosing the data every frame. An
  automatic plane's box shows, in grey, the plane the last frame used ("auto (4.96)"), from the
  render process's concrete camera of that frame (``LiveEvaluation.view_cameras``, which the
  inspector hands over through ``set_view_camera``); its tooltip gives both planes.
"""

from __future__ import annotations

from PySide6.QtGui import QPalette
from PySide6.QtWidgets import QCheckBox, QComboBox, QDoubleSpinBox, QGridLayout, QLabel, QPushButton

from vgraph.camera import Camera
from vgraph.gui.editors import PropertyEditor, list_popup, narrow, register_editor, spin_value

AUTO = "auto"


def plane_text(value: float) -> str:
    """A resolved plane short enough for a narrow box: 3 significant digits, no exponent below 1e6."""
    return f"{value:.0f}" if 1000 <= value < 1e6 else f"{value:.3g}"


class CameraEditor(PropertyEditor):
    """Projection, position, focus, up and field of view, near and far planes, whether it fits the
    data, and a Reset to the declared default (module docstring)."""

    VECTORS = ("position", "focus", "up")

    def build(self):
        grid = QGridLayout()
        self.projection = list_popup(QComboBox())
        self.projection.addItems(["perspective", "orthographic"])
        self.projection.currentTextChanged.connect(self._changed)
        grid.addWidget(QLabel("projection"), 0, 0)
        grid.addWidget(self.projection, 0, 1, 1, 3)
        self.vectors: dict[str, list[QDoubleSpinBox]] = {}
        for row, name in enumerate(self.VECTORS, start=1):
            grid.addWidget(QLabel(name), row, 0)
            self.vectors[name] = [self._spin(-1e6, 1e6) for _ in range(3)]
            for column, spin in enumerate(self.vectors[name], start=1):
                grid.addWidget(spin, row, column)
        self.fov = self._spin(0.1, 179.9)
        grid.addWidget(QLabel("fov"), 4, 0)
        grid.addWidget(self.fov, 4, 1)
        self.reset = QPushButton("Reset")
        self.reset.clicked.connect(lambda: self.emit(self.prop.default))
        grid.addWidget(self.reset, 4, 3)
        self.fit = QCheckBox("fit to data")
        self.fit.setToolTip("frame whatever volume arrives, keeping the direction; near and far "
                            "planes follow the data unless set in the .json")
        self.fit.toggled.connect(self._changed)
        grid.addWidget(self.fit, 5, 1, 1, 3)
        self.planes = {}
        grid.addWidget(QLabel("near, far"), 6, 0)
        for column, name in enumerate(("near", "far"), start=1):
            spin = self._spin(0.0, 1e6)
            spin.setSpecialValueText(AUTO)   # shown at the minimum, 0, which means None
            self.planes[name] = spin
            grid.addWidget(spin, 6, column)
        self.layout_.addLayout(grid)
        self.resolved: tuple[float, float] | None = None   # (near, far) of the last frame
        self._show_planes()

    def _spin(self, low, high) -> QDoubleSpinBox:
        spin = QDoubleSpinBox()
        spin.setRange(low, high)
        spin.setDecimals(4)
        spin.setKeyboardTracking(False)
        spin.valueChanged.connect(self._changed)
        return narrow(spin)

    def _changed(self, *_):
        current: Camera = self.processor.property_values[self.prop.name]
        changes = {name: tuple(spin_value(s, exact) for s, exact in zip(spins, getattr(current, name)))
                   for name, spins in self.vectors.items()}
        changes |= {"projection": self.projection.currentText(), "fov": spin_value(self.fov, current.fov)}
        changes |= {name: (spin_value(spin, getattr(current, name)) or None)
                    for name, spin in self.planes.items()}
        moved = changes["position"] != current.position or changes["focus"] != current.focus
        changes["fit_to_data"] = self.fit.isChecked() and not moved
        self.emit(current.model_dump() | changes)

    def _show(self, value: Camera):
        self.projection.setCurrentText(value.projection)
        for name, spins in self.vectors.items():
            for spin, component in zip(spins, getattr(value, name)):
                spin.setValue(component)
        self.fov.setValue(value.fov)
        self.fit.setChecked(value.fit_to_data)
        for name, spin in self.planes.items():
            spin.setValue(getattr(value, name) or 0.0)
        self._show_planes()

    def set_view_camera(self, camera: Camera | None) -> None:
        """The concrete camera of the last frame (None: not rendered): its planes are what the
        automatic boxes show."""
        resolved = (camera.near, camera.far) if camera is not None and camera.near and camera.far else None
        if resolved != self.resolved:
            self.resolved = resolved
            self._show_planes()

    def _show_planes(self) -> None:
        """Each automatic box shows, in grey, the plane the last frame used."""
        for index, (name, spin) in enumerate(self.planes.items()):
            chosen = self.resolved[index] if self.resolved else None
            auto = spin.value() == spin.minimum()
            spin.setSpecialValueText(AUTO if chosen is None else f"{AUTO} ({plane_text(chosen)})")
            tip = (f"{name} clipping plane, distance from the camera; 0 (auto): planes enclosing "
                   "the data's bounding sphere, chosen every frame")
            if self.resolved:
                tip += f"\nthe last frame used near {self.resolved[0]:.4g}, far {self.resolved[1]:.4g}"
            spin.setToolTip(tip)
            palette = spin.palette()
            grey = self.palette().color(QPalette.PlaceholderText)
            palette.setColor(QPalette.Text, grey if auto else self.palette().color(QPalette.Text))
            spin.setPalette(palette)
            spin.lineEdit().setPalette(palette)


register_editor("camera", CameraEditor)
