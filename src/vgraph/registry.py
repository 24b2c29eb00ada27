"""Which processor types exist: the built-ins (every module of ``vgraph.processors``), plug-ins
registered through the entry-point group ``vgraph.processors``, and modules loaded by name
(``vgraph run --plugin module.path``).

An entry point may name a module (all Processor subclasses defined in it are registered), a
Processor class, or a list of classes.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import warnings
from importlib.metadata import entry_points
from types import ModuleType

from vgraph.errors import VGraphError
from vgraph.processor import Processor

ENTRY_POINT_GROUP = "vgraph.processors"
# The built-in processors are found by name, as plug-ins are: the registry is part of the model,
# which the processors import, so it must not import them (docs/explanations/architecture.md, "Layers").
BUILTINS = "vgraph.processors"


class Registry:
    def __init__(self):
        self.types: dict[str, type[Processor]] = {}
        self.plugins: list[str] = []  # loaded plug-in modules / entry points, for messages
        self.failed_plugins: dict[str, str] = {}
        self._loaded = False

    def ensure_loaded(self) -> None:
        if not self._loaded:
            self._loaded = True
            self._load_builtins()
            self._load_entry_points()

    def register(self, cls: type[Processor], origin: str = "") -> type[Processor]:
        if not (inspect.isclass(cls) and issubclass(cls, Processor)):
            raise VGraphError(f"{origin or cls!r}: not a vgraph Processor class")
        existing = self.types.get(cls.type_name)
        if existing is not None and existing is not cls:
            raise VGraphError(f"{origin or cls.__module__}: processor type '{cls.type_name}' is "
                              f"already defined by {existing.__module__}.{existing.__qualname__}")
        self.types[cls.type_name] = cls
        return cls

    def load_plugin(self, module_name: str) -> None:
        """Import a module by name and register its processors (``--plugin``)."""
        self.ensure_loaded()
        try:
            module = importlib.import_module(module_name)
        except Exception as error:
            raise VGraphError(f"plug-in '{module_name}' could not be imported: {error}") from error
        self._register_object(module, module_name)
        self.plugins.append(module_name)

    def get(self, type_name: str) -> type[Processor]:
        self.ensure_loaded()
        cls = self.types.get(type_name)
        if cls is None:
            raise VGraphError(self.unknown_type_message(type_name))
        return cls

    def unknown_type_message(self, type_name: str) -> str:
        self.ensure_loaded()
        plugins = ", ".join(self.plugins) or "none"
        failed = "".join(f"; {origin} failed to load ({reason})" for origin, reason in self.failed_plugins.items())
        return (f"unknown processor type '{type_name}'; known types: {', '.join(sorted(self.types))}; "
                f"plug-ins loaded: {plugins}{failed}")

    def all(self) -> list[type[Processor]]:
        self.ensure_loaded()
        return [self.types[name] for name in sorted(self.types)]

    # --- loading --------------------------------------------------------------------------------
    def _load_builtins(self) -> None:
        package = importlib.import_module(BUILTINS)
        for info in pkgutil.iter_modules(package.__path__, package.__name__ + "."):
            self._load_guarded(info.name, lambda name=info.name: importlib.import_module(name))

    def _load_entry_points(self) -> None:
        for entry in entry_points(group=ENTRY_POINT_GROUP):
            origin = f"{entry.name} ({entry.value})"
            if self._load_guarded(origin, entry.load):
                self.plugins.append(origin)

    def _load_guarded(self, origin: str, load) -> bool:
        """Load one module or entry point; a broken one is reported (``failed_plugins``, a
        warning, ``vgraph list``) and must not take the other processors down with it."""
        try:
            self._register_object(load(), origin)
            return True
        except Exception as error:
            self.failed_plugins[origin] = f"{type(error).__name__}: {error}"
            warnings.warn(f"vgraph: {origin} failed to load: {error}", stacklevel=3)
            return False

    def _register_object(self, obj, origin: str) -> None:
        if isinstance(obj, ModuleType):
            for _, cls in inspect.getmembers(obj, inspect.isclass):
                if issubclass(cls, Processor) and cls.__module__ == obj.__name__ \
                        and "process" in vars(cls) and not inspect.isabstract(cls):
                    self.register(cls, origin)
        elif isinstance(obj, (list, tuple)):
            for item in obj:
                self.register(item, origin)
        else:
            self.register(obj, origin)


registry = Registry()
