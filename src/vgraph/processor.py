"""The Processor: ports and properties declared once, and one ``process()``.

A processor reads like its description::

    class Grayscale(Processor):
        \"\"\"Luminance of an image, mixed with the original by ``saturation``.\"\"\"
        category = "Image"
        inports = [Inport("image", Image)]
        outports = [Outport("image", Image)]
        saturation = FloatProperty(0.0, min=0.0, max=1.0)

        def process(self, image):
            ...
            return result          # or {"image": result} when there are several outports

``process`` receives one keyword argument per inport (None for an unconnected optional inport, a
list for a ``multiple`` inport) and returns the outputs: a dict by outport name, a single value when
there is exactly one outport, or None for a sink. GL work uses ``self.gl`` (the shared context,
created only when first asked for) and ``self.render_size`` when ``renders_at_size`` is set. A
processor that needs what a frame gives beyond its properties (the GUI's load limit) names those
fields in ``uses_context`` and takes a ``context`` argument too (vgraph.frame_context).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

from vgraph.errors import PropertyError
from vgraph.file_names import expanded
from vgraph.frame_context import FrameContext, checked_uses
from vgraph.gl_context import get_context
from vgraph.ports import Inport, Outport
from vgraph.progress import report as report_progress
from vgraph.properties import Invalidation, Property

if TYPE_CHECKING:
    from vgraph.network import Network

CAMEL_CASE = re.compile(r"^[A-Z][A-Za-z0-9]*$")


class Processor:
    type_name: ClassVar[str]
    category: ClassVar[str] = "Other"
    description: ClassVar[str] = ""
    inports: ClassVar[list[Inport]] = []
    outports: ClassVar[list[Outport]] = []
    properties: ClassVar[dict[str, Property]] = {}
    renders_at_size: ClassVar[bool] = False  # output depends on the requested image size
    uses_context: ClassVar[tuple[str, ...]] = ()  # FrameContext fields process(..., context) reads

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        cls.type_name = cls.__dict__.get("type_name", cls.__name__)
        if not CAMEL_CASE.match(cls.type_name):
            raise ValueError(f"processor type name {cls.type_name!r} must be CamelCase")
        if not cls.__dict__.get("description") and cls.__doc__:
            cls.description = cls.__doc__.strip().splitlines()[0]
        inherited = {}
        for base in reversed(cls.__mro__[1:]):
            inherited.update(getattr(base, "properties", {}))
        own = {name: p for name, p in cls.__dict__.items() if isinstance(p, Property)}
        cls.properties = inherited | own
        for ports in (cls.inports, cls.outports):
            names = [p.name for p in ports]
            if len(set(names)) != len(names):
                raise ValueError(f"{cls.type_name}: duplicate port names {names}")
        cls.uses_context = checked_uses(cls.type_name, cls.uses_context, [p.name for p in cls.inports])

    def __init__(self, id: str | None = None, **values):
        self.id = id or self.type_name[0].lower() + self.type_name[1:]
        self.network: Network | None = None
        self.position: tuple[float, float] = (0.0, 0.0)
        self.property_values = {name: p.default for name, p in self.properties.items()}
        self.invalid_level = Invalidation.OUTPUT  # nothing computed yet
        self.initialized = False
        self.outputs: dict[str, object] = {}
        self.wanted: frozenset[str] = frozenset()  # on-demand outports read this evaluation (scheduler)
        self.inputs: dict[str, object] = {}  # what the last process() received (sinks show it)
        self.evaluation_count = 0
        self.last_seconds: float | None = None
        self.last_error: str | None = None
        self.render_size: tuple[int, int] = (512, 512)
        self.evaluated_context: FrameContext | None = None  # the (narrowed) context of the last process()
        for name, value in values.items():
            self.set_property(name, value)

    # --- declarations ---------------------------------------------------------------------------
    @classmethod
    def inport(cls, name: str) -> Inport | None:
        return next((p for p in cls.inports if p.name == name), None)

    @classmethod
    def outport(cls, name: str) -> Outport | None:
        return next((p for p in cls.outports if p.name == name), None)

    @classmethod
    def describe(cls) -> dict:
        """The entry of ``vgraph list --json``."""
        ports = [{"name": p.name, "direction": p.direction, "data_type": p.type_name,
                  **({"optional": p.optional, "multiple": p.multiple} if p.direction == "in" else {})}
                 for p in (*cls.inports, *cls.outports)]
        return {"type": cls.type_name, "category": cls.category, "description": cls.description,
                "ports": ports, "properties": [p.describe() for p in cls.properties.values()]}

    # --- properties -----------------------------------------------------------------------------
    def set_property(self, name: str, value, base_dir=None) -> None:
        """Validate and store a value; invalidate what the property says; follow links. File names
        inside the value (a TF file) are relative to ``base_dir``, by default the network's folder."""
        prop = self.properties.get(name)
        if prop is None:
            known = ", ".join(self.properties) or "none"
            raise PropertyError(f"{self.id}.{name}",
                                f"{self.type_name} has no property '{name}' (its properties: {known})")
        if base_dir is None and self.network is not None:
            base_dir = self.network.base_dir
        value = prop.validate(value, f"{self.id}.{name}", base_dir)
        if value == self.property_values[name]:
            return
        self.property_values[name] = value
        if self.network is not None:
            self.network.property_changed(self, name)
        else:
            self.invalidate(prop.invalidates)

    def invalidate(self, level: Invalidation = Invalidation.OUTPUT) -> None:
        self.invalid_level = max(self.invalid_level, level)

    def resolve_path(self, path: str) -> Path:
        """A file path property's value, relative to the network file's folder if it has one."""
        resolved = expanded(path)
        base = self.network.base_dir if self.network is not None else None
        return resolved if resolved.is_absolute() or base is None else base / resolved

    # --- evaluation -----------------------------------------------------------------------------
    @property
    def gl(self):
        """The process's shared moderngl context (created on first use, never by a processor)."""
        return get_context()

    def wants(self, outport: str) -> bool:
        """Whether process() should produce ``outport`` this time: always for ordinary outports;
        for an ``on_demand`` one only when something reads it (the scheduler sets ``wanted``)."""
        port = self.outport(outport)
        return port is None or not port.on_demand or outport in self.wanted

    def report_progress(self, done: float, total: float, what: str = "") -> None:
        """Say how far a long ``process()`` is: ``done`` of ``total`` steps of ``what`` ("reading
        bricks"). The GUI shows it as a progress bar; nothing happens when nobody listens, so a
        loop may call it every step (``vgraph.progress``)."""
        report_progress(done, total, what)

    def initialize(self) -> None:
        """Called once, just before the first process(); never for processors not evaluated."""

    def check(self) -> None:
        """Refuse property values that are impossible together (raise VGraphError naming the
        property); called when a network file is loaded, so ``validate`` catches what ``run`` would."""

    def awaiting(self) -> str | None:
        """What the processor waits for from the user before it can run at all ("a volume file"),
        or None. The GUI does not run it meanwhile and its node says so, as for an unconnected
        inport: a new source without a file is no error (``vgraph run`` still refuses it by name)."""
        return None

    def values_in_use(self) -> dict:
        """The values its automatic properties (those left None: "from the file") took in the
        last run, by property name; the inspector shows them greyed in place of a placeholder."""
        return {}

    def frame_summary(self) -> str:
        """What its last frame drew beyond its outputs, in a line for the inspector (a bricked
        frame's levels and error bound); empty when there is nothing to say."""
        return ""

    def inapplicable(self) -> set[str]:
        """Properties that do not apply to the current values (the raw-file settings of a source
        whose file has a header); the inspector hides them."""
        return set()

    def visible_content(self) -> str | None:
        """What the inputs of the last process() should make visible, in words ("12% of the voxels
        are visible under the transfer function"), or None when nothing or unknown. A renderer that
        says so and still produced a uniform image is reported (``scheduler.blank_image_warning``)."""
        return None

    def shown_content(self) -> list | None:
        """What a renderer's inputs of the last process() should show: one
        ``vgraph.shown_content.Shown`` per input (empty: no input yet); None for a processor that
        renders nothing or does not say. A uniform image of a renderer that says is diagnosed by
        ``vgraph.blank_causes`` (the value range, the transfer function, clip planes, the camera)."""
        return None

    def process(self, **inputs):
        raise NotImplementedError(f"{self.type_name} does not implement process()")

    def __repr__(self) -> str:
        return f"<{self.type_name} '{self.id}'>"
