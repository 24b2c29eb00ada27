"""What a keyframe track sets (vgraph.tracks): a whole property, ``id.property``, or one field of a
property whose value has fields (a camera, a transfer function), ``id.property.field``: e.g.
``eep.camera.fov`` or ``rc.transfer_function.tf_shift`` (the preset shift, without the points).

A target validates a keyframe's value (a field's value is checked by building the property's value
with it, so the model's own rules apply), writes it back as JSON, reads and sets it on a network,
and says its ``kind``: a property's kind, or for a field, from its value: ``float`` for a number,
``vector`` for numbers, else ``step`` (vgraph.tracks.INTERPOLATORS).
"""

from __future__ import annotations

from dataclasses import dataclass

from pydantic import BaseModel, ValidationError
from pydantic_core import to_jsonable_python

from vgraph.errors import PropertyError, VGraphError
from vgraph.network import Network, split_address
from vgraph.properties import Property


def target_of(network: Network, address: str):
    """The PropertyTarget or FieldTarget of ``address``; VGraphError naming what exists if none."""
    parts = str(address).split(".")
    if len(parts) not in (2, 3) or not all(parts):
        raise VGraphError(f"'{address}' is not a track address: ID.PROPERTY or ID.PROPERTY.FIELD")
    processor_id, _ = split_address(".".join(parts[:2]), "property")
    if processor_id not in network:
        known = ", ".join(network.processors) or "none"
        raise VGraphError(f"no processor '{processor_id}' in the network (its processors: {known})")
    whole = ".".join(parts[:2])
    prop = network._property(whole)
    if len(parts) == 2:
        return PropertyTarget(whole, prop)
    return FieldTarget.of(network, whole, prop, parts[2])


@dataclass(frozen=True)
class PropertyTarget:
    address: str
    prop: Property

    @property
    def kind(self) -> str:
        return self.prop.kind

    @property
    def integer(self) -> bool:
        return getattr(self.prop, "integer", False)

    def validate(self, value, base_dir=None):
        return self.prop.validate(value, self.address, base_dir)

    def to_json(self, value):
        return self.prop.to_json(value)

    def set(self, network: Network, value) -> None:
        network.set(self.address, value)


@dataclass(frozen=True)
class FieldTarget:
    address: str        # the property's: "id.property"
    field: str
    kind: str
    base: BaseModel     # the property's value when the track was made: a field is checked within it
    integer: bool = False

    @classmethod
    def of(cls, network: Network, address: str, prop: Property, field: str) -> "FieldTarget":
        current = network.get(address)
        if not isinstance(current, BaseModel):
            raise PropertyError(f"{address}.{field}", f"a {prop.kind} property has no fields; animate "
                                                      f"{address} itself")
        fields = type(current).model_fields
        if field not in fields:
            raise PropertyError(f"{address}.{field}", f"{type(current).__name__} has no field '{field}' "
                                                      f"(its fields: {', '.join(fields)})")
        value = getattr(current, field)
        return cls(address, field, _kind_of(value), current,
                   isinstance(value, (tuple, list)) and all(isinstance(v, int) for v in value))

    def validate(self, value, base_dir=None):
        # The field checked as part of a whole value: the model's own rules (ranges, types) apply.
        try:
            built = type(self.base).model_validate({**self.base.model_dump(), self.field: value})
        except ValidationError as error:
            reasons = "; ".join(e["msg"] for e in error.errors())
            raise PropertyError(f"{self.address}.{self.field}", f"invalid value {value!r}: {reasons}") from None
        return getattr(built, self.field)

    def to_json(self, value):
        return to_jsonable_python(value)

    def set(self, network: Network, value) -> None:
        current = network.get(self.address)
        network.set(self.address, type(current).model_validate({**current.model_dump(), self.field: value}))


def _kind_of(value) -> str:
    if isinstance(value, bool) or value is None:
        return "step"
    if isinstance(value, (int, float)):
        return "float"
    if isinstance(value, (tuple, list)) and value and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                          for v in value):
        return "vector"
    return "step"
