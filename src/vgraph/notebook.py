"""vgraph in Jupyter: a Viewer that renders a network headless and renders again on every change.

``Image`` and ``Network`` show inline by themselves (their ``_repr_png_``); the Viewer adds sliders
and needs ipywidgets, the ``notebook`` extra (``pip install 'vgraph[notebook]'``)::

    from vgraph.notebook import Viewer
    Viewer(net, size=(384, 384), properties=["rc.sampling_rate", "rc.compositing"])

Azimuth and elevation orbit every camera (each link group once, vgraph.animation.CameraOrbit)
from where the cameras were when the Viewer was made. Each chosen property gets the widget its
declaration calls for: a slider for an int or float property with a range (logarithmic when the
range spans more than two decades), a dropdown for an option or a transfer function (its presets
by name), a checkbox for a bool, a number box otherwise. An int property without a maximum on a processor whose volume has time steps (a
VolumeSource's ``time_step``) slides over those steps. Rendering is synchronous, on release of a
slider; errors show in the status line under the picture instead of being raised.
"""

from __future__ import annotations

import html
import math
import time

try:
    import ipywidgets as widgets
except ImportError as error:  # say which extra brings it
    raise ImportError("vgraph.notebook needs ipywidgets: pip install 'vgraph[notebook]'") from error

from vgraph.animation import CameraOrbit
from vgraph.errors import VGraphError
from vgraph.image import Image
from vgraph.network import Network, split_address
from vgraph.properties import (BoolProperty, FloatProperty, IntProperty, OptionProperty,
                               TransferFunctionProperty)
from vgraph.scheduler import default_target
from vgraph.transfer_function import PRESETS

SLIDER_STEPS = 200  # a float slider moves in this many steps over its range
LOG_RANGE = 100.0   # max / min from which a float slider is logarithmic
INT_LIMIT = 2**31 - 1


class Viewer(widgets.VBox):
    """The network's picture with orbit sliders and widgets for chosen properties."""

    def __init__(self, network: Network, size=(384, 384), properties=(), target: str | None = None):
        self.network = network
        self.size = (int(size[0]), int(size[1]))
        self.target = target or default_target(network)
        self.orbit = CameraOrbit(network)
        self.image = widgets.Image(format="png", width=self.size[0], height=self.size[1])
        self.status = widgets.HTML()
        self.azimuth = _slider(widgets.FloatSlider, "azimuth", 0.0, min=-180.0, max=180.0, step=1.0)
        self.elevation = _slider(widgets.FloatSlider, "elevation", 0.0, min=-90.0, max=90.0, step=1.0)
        for slider in (self.azimuth, self.elevation):
            slider.observe(self._turn, names="value")
        self.render()  # first: the volumes' time steps are known afterwards
        self.controls = {address: self._control(address) for address in properties}
        super().__init__([self.image, widgets.HBox([self.azimuth, self.elevation]),
                          *self.controls.values(), self.status])

    def render(self) -> bytes | None:
        """Evaluate the target at the Viewer's size and show it; the PNG bytes, or None (and the
        error in the status line) if the evaluation failed."""
        start = time.perf_counter()
        try:
            self.network.update(self.target, size=self.size)
            image = self.network.output(self.target)
            if not isinstance(image, Image):
                raise VGraphError(f"{self.target} holds {type(image).__name__}, not an image")
            self.image.value = image._repr_png_()
        except VGraphError as error:
            self.status.value = f"<span style='color:#c00'>{html.escape(str(error))}</span>"
            return None
        self.status.value = f"{self.target}: {self.size[0]}x{self.size[1]} in " \
                            f"{time.perf_counter() - start:.2f} s"
        return self.image.value

    def _turn(self, change=None) -> None:
        self.orbit.turn(self.azimuth.value, self.elevation.value)
        self.render()

    def _control(self, address: str):
        widget = property_widget(self.network, address)

        def changed(change):
            try:
                self.network.set(address, change["new"])
            except VGraphError as error:
                self.status.value = f"<span style='color:#c00'>{html.escape(str(error))}</span>"
                return
            self.render()
        widget.observe(changed, names="value")
        return widget


def property_widget(network: Network, address: str):
    """The widget for property ``address`` ('id.name'), from its declaration, showing its value."""
    prop = network._property(address)  # names the processor's properties if unknown
    value = network.get(address)
    if isinstance(prop, BoolProperty):
        return widgets.Checkbox(value=value, description=address, indent=False)
    if isinstance(prop, OptionProperty):
        return _slider(widgets.Dropdown, address, value, options=list(prop.choices))
    if isinstance(prop, TransferFunctionProperty):
        # The presets by name (a property accepts a name); the value set in the network comes first.
        shown = [("as set", value)] + [(name, name) for name in PRESETS]
        return widgets.Dropdown(options=shown, value=value, description=address,
                                style={"description_width": "initial"})
    if isinstance(prop, IntProperty):
        low = prop.min if prop.min is not None else -INT_LIMIT
        high = prop.max if prop.max is not None else _last_time_step(network, address)
        if prop.min is not None and high is not None:
            return _slider(widgets.IntSlider, address, value, min=low, max=high)
        return _slider(widgets.BoundedIntText, address, value, min=low,
                       max=high if high is not None else INT_LIMIT)
    if isinstance(prop, FloatProperty):
        if prop.min is None or prop.max is None:
            return _slider(widgets.BoundedFloatText, address, value,
                           min=prop.min if prop.min is not None else -1e308,
                           max=prop.max if prop.max is not None else 1e308)
        if prop.min > 0 and prop.max / prop.min >= LOG_RANGE:
            low, high = math.log10(prop.min), math.log10(prop.max)
            return _slider(widgets.FloatLogSlider, address, value, base=10, min=low, max=high,
                           step=(high - low) / SLIDER_STEPS)
        return _slider(widgets.FloatSlider, address, value, min=prop.min, max=prop.max,
                       step=(prop.max - prop.min) / SLIDER_STEPS)
    raise VGraphError(f"{address}: the Viewer has no widget for a {prop.kind} property (it has "
                      f"them for bool, option, int, float and transfer-function properties)")


def _last_time_step(network: Network, address: str) -> int | None:
    """time_steps - 1 of a volume the property's processor made, if it has several."""
    processor = network[split_address(address, "property")[0]]
    steps = [getattr(data, "time_steps", 1) for data in processor.outputs.values()]
    return max(steps) - 1 if steps and max(steps) > 1 else None


def _slider(kind, description: str, value, **options):
    # Render on release, not on every step of a drag: rendering is synchronous.
    extra = {"continuous_update": False} if "continuous_update" in kind.class_trait_names() else {}
    return kind(value=value, description=description, style={"description_width": "initial"},
                **extra, **options)
