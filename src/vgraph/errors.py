"""The errors vgraph raises. Each one carries the place it comes from (file, processor, property,
JSON path, shader line) so that a message alone tells a user what to fix.

Everything a user can cause derives from ``VGraphError``; the CLI maps it to exit code 2.
Anything else escaping vgraph is an internal failure (exit code 1).
"""

from __future__ import annotations


class VGraphError(Exception):
    """Bad input of any kind: a file, a network, a property value, a port connection."""


class VGraphWarning(UserWarning):
    """Something works but is probably not what the user wants (a flat volume, an empty image).
    The CLI prints these as ``vgraph: warning: ...``; the GUI shows them in its log."""


class PropertyError(VGraphError, ValueError):
    """A property value was rejected. Names processor and property."""

    def __init__(self, where: str, reason: str):
        self.where = where
        self.reason = reason
        super().__init__(f"{where}: {reason}")


class PortError(VGraphError):
    """A connection was refused (unknown port, incompatible data types, taken inport)."""


class CycleError(PortError):
    """A connection would close a cycle in the network."""


class NetworkFileError(VGraphError):
    """A .json network could not be read. ``problems`` lists (JSON path, reason) pairs."""

    def __init__(self, file: str, problems: list[tuple[str, str]]):
        self.file = file
        self.problems = problems
        lines = [f"{file}: {path or '(top level)'}: {reason}" for path, reason in problems]
        super().__init__("\n".join(lines))


class WritePathError(NetworkFileError):
    """A network file asks a writer to write outside the file's own folder. ``paths`` lists
    (processor id, resolved path) pairs; loading again with those folders allowed accepts them."""

    def __init__(self, file: str, problems: list[tuple[str, str]], paths: list):
        self.paths = paths
        super().__init__(file, problems)


class VolumeFileError(VGraphError):
    """A volume file could not be read. Names the file and, where known, the header field."""

    def __init__(self, file: str, reason: str, field: str | None = None):
        self.file = str(file)
        self.field = field
        self.reason = reason
        place = f"{self.file} [{field}]" if field else self.file
        super().__init__(f"{place}: {reason}")


class TimeStepError(VolumeFileError):
    """The time point asked for is not in the file; ``time_steps`` is how many it holds (so that
    VolumeSource can name its own property and the count)."""

    def __init__(self, file, time_step, time_steps: int):
        self.time_step, self.time_steps = time_step, time_steps
        held = "1 time point (0)" if time_steps == 1 else \
            f"{time_steps} time points (0 .. {time_steps - 1})"
        super().__init__(file, f"time step {time_step} is out of range: the file holds {held}",
                         "time step")


class MeshFileError(VolumeFileError):
    """A mesh or surface file could not be read. Names the file and, where known, the part of it
    (a cell block, an array, the points)."""


class OutputFileError(VGraphError):
    """A result could not be written (missing or read-only folder, full disk, a folder in the way).
    Names the file; an existing file of that name is left as it was."""

    def __init__(self, file, reason: str):
        self.file = str(file)
        self.reason = reason
        super().__init__(f"cannot write {self.file}: {reason}")


class ShaderError(VGraphError):
    """A GLSL program failed to compile or link. Names the shader file, line and processor."""

    def __init__(self, message: str, file: str | None = None, line: int | None = None,
                 processor: str | None = None):
        self.file, self.line, self.processor = file, line, processor
        place = ":".join(str(p) for p in (file, line) if p is not None)
        who = f"processor {processor}: " if processor else ""
        super().__init__(f"{who}{place + ': ' if place else ''}{message}")


class ProcessorError(VGraphError):
    """A processor failed while it ran. Names its id and type; the cause is chained. ``internal``
    is True when the cause was a bug (not a VGraphError), which the CLI reports as exit code 1."""

    def __init__(self, processor_id: str, type_name: str, reason: str, internal: bool = False):
        self.processor_id = processor_id
        self.type_name = type_name
        self.reason = reason
        self.internal = internal
        super().__init__(f"processor '{processor_id}' ({type_name}): {reason}")


def positive_pair(value, name: str, parts: str, error: type[VGraphError] = VGraphError) -> tuple[int, int]:
    """``value`` as two positive integers (an image's size, a grid of tiles; 2.0 is 2, 2.5 is
    refused); otherwise ``error`` naming it: "{name} must be two positive integers {parts}, got ..."."""
    try:
        items = tuple(value)
        first, second = (int(v) for v in items)
    except (TypeError, ValueError, OverflowError):
        first = second = 0
    if first < 1 or second < 1 or (first, second) != items:
        raise error(f"{name} must be two positive integers {parts}, got {value!r}")
    return first, second
