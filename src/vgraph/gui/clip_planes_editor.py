"""The inspector's editor of clip planes (vgraph.clipping.ClipPlanesProperty, kind "clip_planes").

One row per plane: the normal and a point on the plane (world units, three boxes each) and a
button that removes the plane; "Add plane" appends one. The side the normal points into is kept.
A new plane copies the last one with its normal reversed (a slab, the usual second cut), or is
the plane x = 0 keeping +x when there is none. Every change emits the whole list, as plain
{"normal", "point"} dicts: the workspace validates it (a zero normal is refused there and the
inspector shows the planes again).
"""

from __future__ import annotations

from PySide6.QtWidgets import QDoubleSpinBox, QGridLayout, QLabel, QPushButton, QToolButton, QVBoxLayout

from vgraph.clipping import MAX_CLIP_PLANES
from vgraph.gui.editors import UNBOUNDED, PropertyEditor, narrow, register_editor, spin_value

FIRST_PLANE = {"normal": (1.0, 0.0, 0.0), "point": (0.0, 0.0, 0.0)}


def as_dicts(planes) -> list[dict]:
    return [{"normal": tuple(plane.normal), "point": tuple(plane.point)} for plane in planes]


class ClipPlanesEditor(PropertyEditor):
    """Rows of (normal, point) with remove buttons, and an Add button."""

    def build(self):
        box = QVBoxLayout()
        box.setContentsMargins(0, 0, 0, 0)
        self.grid = QGridLayout()
        box.addLayout(self.grid)
        self.add = QPushButton("Add plane")
        self.add.setToolTip("append a plane (at most %d); the side its normal points into is kept" % MAX_CLIP_PLANES)
        self.add.clicked.connect(self.add_plane)
        box.addWidget(self.add)
        self.layout_.addLayout(box)
        self.rows: list[dict] = []  # per plane: {"normal": [spins], "point": [spins], "remove": button}

    # --- rows -----------------------------------------------------------------------------------
    def _spin(self) -> QDoubleSpinBox:
        spin = QDoubleSpinBox()
        spin.setRange(-UNBOUNDED, UNBOUNDED)
        spin.setDecimals(4)
        spin.setKeyboardTracking(False)
        spin.valueChanged.connect(self._changed)
        return narrow(spin)

    def _set_row_count(self, count: int) -> None:
        while len(self.rows) > count:
            row = self.rows.pop()
            for widget in (*row["normal"], *row["point"], row["remove"], *row["labels"]):
                self.grid.removeWidget(widget)
                widget.deleteLater()
        while len(self.rows) < count:
            index = len(self.rows)
            row = {"normal": [self._spin() for _ in range(3)], "point": [self._spin() for _ in range(3)],
                   "labels": [QLabel(f"normal {index + 1}"), QLabel("point")], "remove": QToolButton()}
            row["remove"].setText("\u2212")
            row["remove"].setToolTip("remove this plane")
            row["remove"].clicked.connect(lambda _=False, index=index: self.remove_plane(index))
            for line, name in enumerate(("normal", "point")):
                self.grid.addWidget(row["labels"][line], 2 * index + line, 0)
                for column, spin in enumerate(row[name], start=1):
                    self.grid.addWidget(spin, 2 * index + line, column)
            self.grid.addWidget(row["remove"], 2 * index, 4)
            self.rows.append(row)
        self.add.setEnabled(count < MAX_CLIP_PLANES)

    # --- values ---------------------------------------------------------------------------------
    def current(self) -> list[dict]:
        return as_dicts(self.processor.property_values[self.prop.name])

    def value(self) -> list[dict]:
        """The planes the boxes show (components the boxes still show rounded keep their value)."""
        planes = []
        for row, exact in zip(self.rows, self.current()):
            planes.append({name: tuple(spin_value(spin, e) for spin, e in zip(row[name], exact[name]))
                           for name in ("normal", "point")})
        return planes

    def _changed(self, *_):
        self.emit(self.value())

    def add_plane(self) -> None:
        planes = self.current()
        if planes:
            last = planes[-1]
            planes.append({"normal": tuple(-v for v in last["normal"]), "point": last["point"]})
        else:
            planes.append(dict(FIRST_PLANE))
        self.emit(planes[:MAX_CLIP_PLANES])

    def remove_plane(self, index: int) -> None:
        planes = self.current()
        if 0 <= index < len(planes):
            del planes[index]
            self.emit(planes)

    def _show(self, value):
        self._set_row_count(len(value))
        for row, plane in zip(self.rows, value):
            for name in ("normal", "point"):
                for spin, component in zip(row[name], getattr(plane, name)):
                    spin.setValue(component)


register_editor("clip_planes", ClipPlanesEditor)
