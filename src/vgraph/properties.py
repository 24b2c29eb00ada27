"""Typed properties, declared once on a processor class.

A declaration such as ``sampling_rate = FloatProperty(1.0, min=0.1, max=16)`` gives the default, the
range, the validation (a pydantic TypeAdapter), the JSON form, the row in ``vgraph list`` and, later,
the GUI widget. On an instance the attribute reads the current value; assigning validates it.

A change invalidates the processor's output (``Invalidation.OUTPUT``: process() runs again). There
is one level: GL programs are looked up by their define set in process() (compiled once per set),
so no property needs a rebuild step of its own (docs/explanations/architecture.md). ``Invalidation.RESOURCES``
remains as an alias of OUTPUT for plug-ins that still declare it.
"""

from __future__ import annotations

from enum import IntEnum
from typing import Annotated, Literal

from pydantic import (AfterValidator, BeforeValidator, Field, StrictBool, StrictInt, TypeAdapter, ValidationError,
                      ValidationInfo)
from pydantic_core import PydanticCustomError

from vgraph.camera import Camera
from vgraph.errors import PropertyError
from vgraph.file_names import check_file_name, shown
from vgraph import gradient_opacity, transfer_function_2d
from vgraph.labels import LabelTable
from vgraph.markups import Markups
from vgraph.ports import SNAKE_CASE
from vgraph.transfer_function import TransferFunction, preset_or_file


class Invalidation(IntEnum):
    VALID = 0
    OUTPUT = 1
    RESOURCES = 1  # an alias of OUTPUT (the level was dropped; see the module docstring)


def _not_bool(value):
    if isinstance(value, bool):
        raise ValueError("expected a number, not a boolean")
    return value


_NOT_BOOL = BeforeValidator(_not_bool)


class Property:
    """Base of all property kinds. Subclasses set ``kind`` and build ``_value_type``."""

    kind = "property"

    def __init__(self, default, *, label: str | None = None, doc: str = "",
                 invalidates: Invalidation = Invalidation.OUTPUT):
        self.label = label
        self.doc = doc
        self.invalidates = invalidates
        self.name = ""
        self._adapter = TypeAdapter(self._value_type())
        self.default = self.validate(default, "default")

    # --- declaration ----------------------------------------------------------------------------
    def __set_name__(self, owner, name: str):
        if not SNAKE_CASE.match(name):
            raise ValueError(f"{owner.__name__}.{name}: property names must be snake_case")
        self.name = name
        self.label = self.label or name.replace("_", " ").capitalize()

    def __get__(self, processor, owner=None):
        if processor is None:
            return self
        return processor.property_values[self.name]

    def __set__(self, processor, value):
        processor.set_property(self.name, value)

    # --- values ---------------------------------------------------------------------------------
    def _value_type(self):
        raise NotImplementedError

    def validate(self, value, where: str, base_dir=None):
        """The value as stored, or PropertyError naming ``where`` and the reason. ``base_dir`` is
        the folder relative file names in the value are read from (the network file's)."""
        try:
            return self._adapter.validate_python(value, context={"base_dir": base_dir})
        except ValidationError as error:
            reasons = "; ".join(_describe(e) for e in error.errors())
            raise PropertyError(where, f"invalid value {_shown_value(value)}: {reasons}") from None

    def to_json(self, value):
        return self._adapter.dump_python(value, mode="json")

    def describe(self) -> dict:
        """The row of ``vgraph list --json``."""
        return {"name": self.name, "type": self.kind, "default": self.to_json(self.default),
                "min": getattr(self, "min", None), "max": getattr(self, "max", None),
                "choices": list(getattr(self, "choices", [])) or None, "doc": self.doc}


def _shown_value(value) -> str:
    """A value in a message, cut short: a 5000-character name or a 900-deep list is not repeated."""
    if isinstance(value, str):
        return shown(value)
    text = repr(value)
    return text if len(text) <= 80 else f"{text[:72]} ... ({len(text)} characters)"


def _describe(error: dict) -> str:
    location = ".".join(str(p) for p in error.get("loc", ()))
    return f"{location}: {error['msg']}" if location else error["msg"]


class FloatProperty(Property):
    kind = "float"

    def __init__(self, default: float, *, min: float | None = None, max: float | None = None, **kw):
        self.min, self.max = min, max
        super().__init__(default, **kw)

    def _value_type(self):
        return Annotated[float, Field(ge=self.min, le=self.max, allow_inf_nan=False), _NOT_BOOL]


class IntProperty(Property):
    """A whole number in ``min``..``max``; ``choices``, where given, the only ones allowed (a range
    cannot say "6, 18 or 26")."""

    kind = "int"

    def __init__(self, default: int, *, min: int | None = None, max: int | None = None,
                 choices: tuple[int, ...] = (), **kw):
        self.min, self.max = min, max
        self.choices = tuple(choices)
        super().__init__(default, **kw)

    def _value_type(self):
        number = Annotated[StrictInt, Field(ge=self.min, le=self.max)]
        return Annotated[number, AfterValidator(self._one_of_choices)] if self.choices else number

    def _one_of_choices(self, value: int) -> int:
        if value not in self.choices:
            *first, last = (str(c) for c in self.choices)
            raise PydanticCustomError("int_choice", "must be {allowed}",
                                      {"allowed": f"{', '.join(first)} or {last}" if first else last})
        return value


class BoolProperty(Property):
    kind = "bool"

    def _value_type(self):
        return StrictBool


class OptionProperty(Property):
    kind = "option"

    def __init__(self, default: str, *, choices: list[str], **kw):
        self.choices = tuple(choices)
        super().__init__(default, **kw)

    def _value_type(self):
        return Literal[self.choices]


class StringProperty(Property):
    kind = "string"

    def _value_type(self):
        return str


class FilePathProperty(StringProperty):
    """A path; relative paths are resolved against the network file's folder when used.
    ``filters`` are the file patterns a file dialog offers, e.g. ("*.png", "*.jpg"). ``writes``
    marks an output path: one that comes from a network file must stay inside the file's folder
    unless the user allows more (docs/reports/reliability.md)."""

    kind = "file_path"

    def __init__(self, default: str = "", *, filters: tuple[str, ...] = ("*",), writes: bool = False,
                 **kw):
        self.filters = tuple(filters)
        self.writes = writes
        super().__init__(default, **kw)

    def _value_type(self):
        return Annotated[str, AfterValidator(check_file_name)]

    def describe(self) -> dict:
        return super().describe() | {"filters": list(self.filters), "writes": self.writes}




class VectorProperty(Property):
    """A fixed-length vector of floats (or ints with ``integer=True``), each within [min, max].
    With ``optional=True`` the value may be None (e.g. "take the spacing from the file")."""

    kind = "vector"

    def __init__(self, default, *, size: int | None = None, min: float | None = None,
                 max: float | None = None, integer: bool = False, optional: bool = False, **kw):
        self.size = size if size is not None else len(default)
        self.min, self.max, self.integer, self.optional = min, max, integer, optional
        super().__init__(default, **kw)

    def _value_type(self):
        number = StrictInt if self.integer else Annotated[float, Field(allow_inf_nan=False), _NOT_BOOL]
        item = Annotated[number, Field(ge=self.min, le=self.max)]
        vector = tuple[(item,) * self.size]
        return vector | None if self.optional else vector

    def describe(self) -> dict:
        return super().describe() | {"size": self.size, "optional": self.optional}


class DictProperty(Property):
    """Named numbers (e.g. a function's parameters); an empty dict means "the defaults". The owner
    checks the names and ranges, since they depend on its other properties."""

    kind = "dict"

    def _value_type(self):
        number = Annotated[float, Field(allow_inf_nan=False), _NOT_BOOL]
        return dict[str, number | list[number]]


class ColorProperty(Property):
    """RGBA in [0, 1]; an RGB triple gets alpha 1."""

    kind = "color"

    def _value_type(self):
        channel = Annotated[float, Field(ge=0.0, le=1.0, allow_inf_nan=False), _NOT_BOOL]
        return Annotated[tuple[channel, channel, channel, channel], BeforeValidator(_add_alpha)]


class TransferFunctionProperty(Property):
    """A TransferFunction; a string value names a preset (transfer_function.PRESETS) or a TF file,
    which is read when the value is set (the stored value is the TF itself)."""

    kind = "transfer_function"

    def _value_type(self):
        return Annotated[TransferFunction, BeforeValidator(_preset_or_file)]


def _preset_or_file(value, info: ValidationInfo):
    if isinstance(value, str):
        return preset_or_file(value, (info.context or {}).get("base_dir"))
    return value


class GradientOpacityProperty(Property):
    """A GradientOpacity curve (vgraph.gradient_opacity) or None (off); a string names a preset."""

    kind = "gradient_opacity"

    def _value_type(self):
        return Annotated[gradient_opacity.GradientOpacity | None, BeforeValidator(gradient_opacity.preset)]


class TransferFunction2DProperty(Property):
    """A TransferFunction2D (vgraph.transfer_function_2d) or None (off); a string names a preset."""

    kind = "transfer_function_2d"

    def _value_type(self):
        return Annotated[transfer_function_2d.TransferFunction2D | None,
                         BeforeValidator(transfer_function_2d.preset)]


class CameraProperty(Property):
    kind = "camera"

    def _value_type(self):
        return Camera


class LabelTableProperty(Property):
    """A LabelTable (vgraph.labels): name, colour, opacity and visibility per label value."""

    kind = "label_table"

    def _value_type(self):
        return LabelTable


class MarkupsProperty(Property):
    """Markups (vgraph.markups): named point lists, rulers, angles and closed curves in world
    coordinates; a list of markups is taken for ``{"markups": [...]}``."""

    kind = "markups"

    def _value_type(self):
        return Annotated[Markups, BeforeValidator(_markups_from_list)]


def _markups_from_list(value):
    return {"markups": value} if isinstance(value, (list, tuple)) else value


def _add_alpha(value):
    if isinstance(value, (list, tuple)) and len(value) == 3:
        return (*value, 1.0)
    return value



PROPERTY_KINDS: dict[str, type[Property]] = {
    cls.kind: cls for cls in (FloatProperty, IntProperty, BoolProperty, OptionProperty,
                              StringProperty, FilePathProperty, VectorProperty, DictProperty, ColorProperty,
                              TransferFunctionProperty, GradientOpacityProperty, TransferFunction2DProperty,
                              CameraProperty, LabelTableProperty, MarkupsProperty)
}
