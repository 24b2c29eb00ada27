"""meshio's readers called so that nothing they do on damaged input escapes as anything but a
MeshFileError naming the file, and nothing they print reaches the terminal unasked.

    raw = read_meshio(path)     # a meshio.Mesh

- meshio.read itself prints a failed reader's error and calls sys.exit, so the readers of the
  extension (``.msh`` is ANSYS or Gmsh) are called one by one; each one's exception (meshio and
  numpy raise anything: ReadError, ValueError, IndexError, KeyError, struct.error, EOFError,
  UnicodeDecodeError, OverflowError, SystemExit ...) is collected, and the MeshFileError lists them
  all. A MemoryError is named as such; a missing optional package (h5py, netCDF4) is named with
  the command that installs it.
- meshio prints its warnings with rich (``meshio._common.warn``: "VTU file corrupt ... Skipping",
  "$Nodes not closed by $EndNodes"). While vgraph reads, meshio's ``Console`` is replaced by a
  recorder (one read at a time, under a lock): the warnings of the reader that succeeded come back
  as one VGraphWarning naming the file, shortened, and rich never highlights them (its number
  highlighting took seconds over a 5000-digit line of a damaged file).
- Exodus II files meshio 5.3 fails on (all nodal variables in one ``vals_nod_var``, as the shared
  disk_out_ref.ex2) are read with netCDF4 directly (``_read_exodus``).
"""

from __future__ import annotations

import contextlib
import io
import re
import threading
import warnings
from pathlib import Path

import numpy as np

from vgraph.errors import MeshFileError, VGraphWarning

MESSAGE_CHARS = 200  # of each meshio warning kept in the VGraphWarning
_MARKUP = re.compile(r"\[/?(?:bold|yellow|red|green|blue|italic)\]")
_LOCK = threading.Lock()


def read_meshio(path: Path):
    """The mesh in ``path`` as meshio reads it (module docstring)."""
    from meshio._helpers import _filetypes_from_path, reader_map  # imported when used: meshio takes 40 ms
    reasons = []
    for file_format in _filetypes_from_path(path):
        try:
            with _meshio_messages() as messages:
                raw = reader_map[file_format](str(path))
            _warn_about(path, messages)
            return raw
        except MemoryError:
            raise MeshFileError(path, "too large for memory (or a damaged header asks for an "
                                      "absurd size)") from None
        except ModuleNotFoundError as error:
            raise MeshFileError(path, f"reading {file_format} files needs the {error.name} package, "
                                      f"which is not installed: pip install {error.name}") from None
        except (Exception, SystemExit) as error:  # meshio and numpy raise anything on damaged input
            reasons.append(f"as {file_format}: {type(error).__name__}: "
                           f"{_shortened(str(error).strip()) or '(no message)'}")
            if file_format == "exodus":
                try:
                    return _read_exodus(path)
                except MeshFileError:
                    raise
                except Exception as second:  # noqa: BLE001  (damaged input, as above)
                    reasons.append(f"as Exodus II with netCDF4: {type(second).__name__}: "
                                   f"{_shortened(str(second).strip()) or '(no message)'}")
    raise MeshFileError(path, f"cannot read the mesh (damaged, truncated or not this format): "
                              f"{'; '.join(reasons)}")


class _Recorder:
    """Stands in for rich's Console in meshio._common while vgraph reads: keeps the text."""

    messages: list[str] = []

    def __init__(self, *args, **kwargs):
        pass

    def print(self, text="", *args, **kwargs) -> None:
        _Recorder.messages.append(_MARKUP.sub("", str(text)).strip())


@contextlib.contextmanager
def _meshio_messages():
    """meshio's warnings and info lines during the block, as a list (module docstring)."""
    import meshio._common as common  # imported when used, as read_meshio imports meshio
    with _LOCK, warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")  # numpy's and meshio's Python warnings: we report ourselves
        console, common.Console = common.Console, _Recorder
        _Recorder.messages = messages = []
        try:
            yield messages
        finally:
            common.Console = console


def _warn_about(path: Path, messages: list[str]) -> None:
    kept = [_shortened(m.removeprefix("Warning:").strip()) for m in messages
            if not m.startswith("Info:")]
    if kept:
        warnings.warn(VGraphWarning(f"{path}: meshio: {'; '.join(kept)}"), stacklevel=4)


def _shortened(text: str) -> str:
    return text if len(text) <= MESSAGE_CHARS else text[:MESSAGE_CHARS] + " ..."


def _read_exodus(path: Path):
    """Points, cells and the first time step's nodal variables of an Exodus II file, read with
    netCDF4. meshio 5.3's reader expects one ``vals_nod_var<i>`` per variable and fails with a
    KeyError on files that hold them all in one ``vals_nod_var`` (time, variable, node), as the
    shared disk_out_ref.ex2 does."""
    # imported when used: netCDF4 is optional (only Exodus needs it), meshio takes 40 ms
    import meshio
    import netCDF4
    from meshio.exodus._exodus import categorize, exodus_to_meshio_type

    def text(variable) -> list[str]:
        variable.set_auto_mask(False)
        return [b"".join(row).decode("utf-8", "replace").strip() for row in variable[:]]

    with netCDF4.Dataset(path) as nc:
        var = nc.variables
        if "coord" in var:
            points = np.asarray(var["coord"][:]).T
        else:
            points = np.stack([np.asarray(var[n][:]) for n in ("coordx", "coordy", "coordz") if n in var],
                              axis=1)
        cells = []
        for key in sorted((k for k in var if k.startswith("connect")), key=lambda k: int(k[7:] or 0)):
            kind = exodus_to_meshio_type.get(var[key].elem_type.upper())
            if kind is None:
                raise MeshFileError(path, f"unknown element type {var[key].elem_type!r}", key)
            cells.append((kind, np.asarray(var[key][:]).astype(np.int64) - 1))  # 1-based
        names = text(var["name_nod_var"]) if "name_nod_var" in var else []
        steps = len(var["time_whole"]) if "time_whole" in var else 1
        nodal = {}
        for i, name in enumerate(names):
            if "vals_nod_var" in var:
                nodal[name] = np.asarray(var["vals_nod_var"][0, i], dtype=np.float64)
            elif f"vals_nod_var{i + 1}" in var:
                nodal[name] = np.asarray(var[f"vals_nod_var{i + 1}"][0], dtype=np.float64)
    if steps > 1:
        warnings.warn(VGraphWarning(f"{path}: the file holds {steps} time steps; the first is read"),
                      stacklevel=4)
    present = [n for n in names if n in nodal]
    single, double, triple = categorize(present)
    point_data = {name: nodal[present[i]] for name, i in single}
    point_data |= {name: np.column_stack([nodal[present[i]] for i in group])
                   for name, *group in (*double, *triple)}
    return meshio.Mesh(points, cells, point_data=point_data)
