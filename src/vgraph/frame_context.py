"""The frame context: what one evaluation needs that is not a property.

A property is part of the network (saved, linked, edited, undone). Some things a frame needs are
not: how much the GUI's render process lets a frame read (``load_limit``), which of a frame's
bricks a cluster task draws (``leaf``), whether the frame is one of a drag's (``interactive``: a
ProjectedTetrahedra then draws its mesh's coarse level of detail, vgraph.mesh_lod; a bricked
single-pass frame samples at its coarse level's step, vgraph.bricks.coarse_step). They belong
to the one evaluation that asks for them, so they travel as its explicit argument::

    evaluate(network, ["rc.image"], size, context=FrameContext(load_limit=LoadLimit(bricks=8)))
    network.evaluate("rc.image", context=FrameContext(load_limit=LoadLimit(bricks=8)))

A processor that uses a field says so in its declaration, and its ``process()`` takes the
context as one more keyword argument::

    class BrickedRayCaster(RaycasterBase):
        uses_context = ("load_limit", "leaf")

        def process(self, volume, entry, exit, context):
            ... context.load_limit ...

The scheduler hands such a processor the context narrowed to the fields it declared (the others
read their defaults, as if no frame gave them), and re-runs it, and what is downstream, when one
of those fields differs from its last evaluation; a processor that declares none never receives a
context and is never re-run for one (docs/explanations/architecture.md, "Frame context").

Why an argument and not an attribute the scheduler sets: an attribute set from outside is a
side channel the processor's description does not show, that outlives the frame it was meant for,
and that the network cannot see to invalidate; an argument is read where it is used and gone
after the call. Fields are compared by value when hashable (a frozen ``LoadLimit``) and by
identity otherwise (a ``LeafPass``: each cluster task makes its own).

The image size of an evaluation stays the scheduler's ``render_size`` (``renders_at_size``): it is
asked of every evaluation, read outside ``process()`` too (a slice viewer maps clicks with it),
and is framework state every processor has, not a per-frame extra some processors opt into.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the types of fields that lower layers define; the model imports none of them
    from vgraph.bricks.cache import LoadLimit
    from vgraph.bricks.selection import LeafPass


@dataclass(frozen=True)
class FrameContext:
    """One evaluation's context. A new field is a new line here (with a default that means "not
    given"); processors opt into it by name in ``uses_context``."""

    # reading per frame of progressive processors (the GUI's); None: no limit
    load_limit: LoadLimit | None = None
    # the leaves split's part of a BrickedRayCaster frame; None: the whole frame
    leaf: LeafPass | None = None
    # a frame drawn while the user drags (the GUI's coarse frames): a coarser level of detail does
    interactive: bool = False

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    def narrowed(self, names: tuple[str, ...]) -> FrameContext:
        """This context with only ``names`` kept; the other fields at their defaults."""
        return replace(NO_CONTEXT, **{name: getattr(self, name) for name in names})

    def same_as(self, other: FrameContext | None) -> bool:
        """Whether ``other`` holds the same values (hashable ones equal, others the same object)."""
        return other is not None and all(_same(getattr(self, name), getattr(other, name))
                                         for name in self.field_names())


def _same(a, b) -> bool:
    if a is b:
        return True
    try:
        hash(a), hash(b)
    except TypeError:  # mutable values (arrays inside): only the same object is the same
        return False
    return type(a) is type(b) and a == b


NO_CONTEXT = FrameContext()


def checked_uses(type_name: str, uses: tuple[str, ...], inport_names: list[str]) -> tuple[str, ...]:
    """A processor class's ``uses_context``, refused (ValueError, at class definition) when it
    names no FrameContext field or when an inport is called ``context`` (process() gets both)."""
    if isinstance(uses, str):
        raise ValueError(f"{type_name}.uses_context must be a tuple of field names, got {uses!r}")
    unknown = [name for name in uses if name not in FrameContext.field_names()]
    if unknown:
        raise ValueError(f"{type_name}.uses_context: {', '.join(map(repr, unknown))} is not a "
                         f"FrameContext field (fields: {', '.join(FrameContext.field_names())})")
    if uses and "context" in inport_names:
        raise ValueError(f"{type_name}: an inport named 'context' clashes with the frame context "
                         f"process() receives (uses_context)")
    return tuple(uses)
