"""The services behind a Network's convenience methods (``network_services.NetworkServices``): evaluation
by the scheduler and saving by the file format.

The model (network.py) imports neither: ``vgraph/__init__`` binds this module to every Network
and imports it only when a network is first evaluated or saved, so the model, the scheduler and the
file format import each other in one direction only (docs/explanations/architecture.md).
"""

from __future__ import annotations

import warnings
from pathlib import Path

from vgraph.errors import VGraphError
from vgraph.fileformat import save_network
from vgraph.image import Image
from vgraph.network import Network
from vgraph.scheduler import (BlankImageWarning, blank_image_warning, default_target, evaluate as run,
                              target_data, to_numpy)


def update(network: Network, targets: tuple[str, ...], size, context=None):
    return run(network, targets, size, context=context)


def output(network: Network, target: str):
    return target_data(network, target)


def evaluate(network: Network, target: str | None, size, context=None):
    """One target's data as numpy, with a warning when a renderer drew nothing it should have."""
    target = target or default_target(network)
    run(network, (target,), size, context=context)
    array = to_numpy(target_data(network, target))
    warning = blank_image_warning(network, target, array)
    if warning:
        warnings.warn(BlankImageWarning(warning), stacklevel=3)  # the caller of Network.evaluate
    return array


def picture(network: Network) -> bytes | None:
    """The default target (the Canvas) evaluated as ``vgraph run`` does, as PNG bytes; None (no
    picture, Jupyter shows the text repr) when the network has no image output. Errors of the
    evaluation propagate, so the notebook shows them."""
    try:
        target = default_target(network)
    except VGraphError:
        return None
    run(network, (target,), None)
    image = target_data(network, target)
    return image._repr_png_() if isinstance(image, Image) else None


def pick(network: Network, canvas: str, x: float, y: float):
    from vgraph.picking import pick as pick_pixel  # numerics behind it load on the first pick
    return pick_pixel(network, canvas, x, y)


def save(network: Network, path: str | Path) -> None:
    save_network(network, path)
