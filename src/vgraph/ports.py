"""Typed ports. A port's data type is a Python class; a connection is accepted when the outport's
type is the inport's type or a subclass of it, so a plug-in adds a data type (or a subtype of Volume,
Image, Geometry) just by defining a class.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

SNAKE_CASE = re.compile(r"^[a-z][a-z0-9_]*$")


@dataclass(frozen=True)
class Port:
    name: str
    data_type: type
    description: str = ""

    def __post_init__(self):
        if not SNAKE_CASE.match(self.name):
            raise ValueError(f"port name {self.name!r} must be snake_case")

    @property
    def type_name(self) -> str:
        return self.data_type.__name__


@dataclass(frozen=True)
class Inport(Port):
    optional: bool = False
    multiple: bool = False  # accepts several connections; process() then receives a list

    direction = "in"

    def accepts(self, outport: "Outport") -> bool:
        return issubclass(outport.data_type, self.data_type)


@dataclass(frozen=True)
class Outport(Port):
    # Computed only when something reads it this evaluation (a target, or a connection to a processor
    # being evaluated); process() asks ``self.wants(name)``. E.g. a ray caster's depth image.
    on_demand: bool = False

    direction = "out"
