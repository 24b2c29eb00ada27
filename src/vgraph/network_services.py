"""What a Network does beyond being a model: evaluation, saving, picking and Jupyter's picture.

Evaluation and saving are not the model's business: ``update``, ``output``, ``evaluate``, ``pick``,
``save`` and ``_repr_png_`` (``ServiceMethods``, a base of ``vgraph.network.Network``) forward to
the ``NetworkServices`` the vgraph package binds (``vgraph.services``,
docs/explanations/architecture.md), so the model imports neither the scheduler nor the file format.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from vgraph.errors import VGraphError

if TYPE_CHECKING:  # annotations only: the network imports this module
    from vgraph.network import Network


class NetworkServices(Protocol):
    """What a Network does beyond being a model; the vgraph package binds ``vgraph.services``."""
    def update(self, network: Network, targets: tuple[str, ...], size, context=None): ...
    def output(self, network: Network, target: str): ...
    def evaluate(self, network: Network, target: str | None, size, context=None): ...
    def picture(self, network: Network) -> bytes | None: ...
    def pick(self, network: Network, canvas: str, x: float, y: float): ...
    def save(self, network: Network, path: str | Path) -> None: ...


_services: NetworkServices | None = None


def bind_services(services: NetworkServices) -> None:
    """Give every Network its evaluation and saving (done once, by ``vgraph/__init__``)."""
    global _services
    _services = services


def _bound() -> NetworkServices:
    if _services is None:  # only if vgraph/__init__ was bypassed: it binds before this module is used
        raise VGraphError("no evaluation services are bound to vgraph.network (import vgraph)")
    return _services


class ServiceMethods:
    """The Network's methods that forward to the bound services (the documented scripting API)."""

    def update(self, *targets: str, size: tuple[int, int] | None = None, context=None):
        """Evaluate what ``targets`` need ('id.outport' or a sink's id; default: every sink);
        ``context``: the frame's ``vgraph.frame_context.FrameContext`` (None: no field given)."""
        return _bound().update(self, targets, size, context)

    def output(self, target: str):
        """The data at 'id.outport', or what a sink 'id' received (after update)."""
        return _bound().output(self, target)

    def evaluate(self, target: str | None = None, size: tuple[int, int] | None = None, context=None):
        """Evaluate one target and return its data as numpy: an image as float32 (H, W, 4) with
        row 0 at the top, a volume as its [z, y, x] array (``context`` as for ``update``)."""
        return _bound().evaluate(self, target, size, context)

    def pick(self, canvas: str, x: float, y: float):
        """What lies under pixel (x, y) of ``canvas`` (row 0 at the top): world point, voxel, the
        values of the volumes upstream, the iso-surface point (``vgraph.picking.PickResult``)."""
        return _bound().pick(self, canvas, x, y)

    def _repr_png_(self) -> bytes | None:
        """Jupyter shows a network as its picture (see ``vgraph.services.picture``)."""
        return _bound().picture(self)

    def save(self, path: str | Path) -> None:
        _bound().save(self, path)
