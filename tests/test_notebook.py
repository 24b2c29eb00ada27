"""Jupyter: Image and Network display as PNG, the Viewer's widgets follow the property declarations
and render again on change, and docs/notebooks/first_render.ipynb runs in a real kernel."""

import io
import shutil

import numpy as np
import PIL.Image
import pytest
from IPython.core.formatters import DisplayFormatter

import vgraph
from vgraph import IntProperty, Outport, Processor
from vgraph.image import Image
from vgraph.imagefile import to_uint8
from vgraph.transfer_function import PRESETS
from vgraph.volume import Volume

from helpers.paths import REPO

widgets = pytest.importorskip("ipywidgets")
from vgraph.notebook import Viewer  # noqa: E402  (needs ipywidgets)

SPHERE = REPO / "networks" / "raycast_sphere.json"
NOTEBOOK = REPO / "docs" / "notebooks" / "first_render.ipynb"


@vgraph.register
class StepsToy(Processor):
    """A volume with three time steps, and an image of the current one."""

    category = "Test"
    outports = [Outport("volume", Volume), Outport("image", Image)]
    time_step = IntProperty(0, min=0)

    def process(self):
        volume = Volume(np.zeros((2, 2, 2), np.float32), time_steps=3)
        return {"volume": volume, "image": Image.from_numpy(self.gl, np.full((8, 8), self.time_step / 4))}


def decoded(png: bytes) -> np.ndarray:
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    return np.asarray(PIL.Image.open(io.BytesIO(png)))


def test_an_image_displays_as_its_8_bit_png():
    net = vgraph.load(REPO / "networks" / "grayscale.json")
    net.update("gray.image")
    image = net.output("gray.image")
    assert np.array_equal(decoded(image._repr_png_()), to_uint8(image.to_numpy()))
    assert "image/png" in DisplayFormatter().format(image)[0]


def test_a_network_displays_as_its_canvas():
    net = vgraph.load(SPHERE)
    net.set("canvas.size", [64, 48])
    data, _ = DisplayFormatter().format(net)
    assert np.array_equal(decoded(data["image/png"]), to_uint8(net.evaluate("canvas")))


def test_a_network_without_an_image_output_has_no_picture():
    assert vgraph.Network()._repr_png_() is None
    net = vgraph.Network()
    net.add("FunctionSelector", id="function")  # no sink, no canvas
    assert net._repr_png_() is None
    assert "image/png" not in DisplayFormatter().format(net)[0]


def test_viewer_widgets_follow_the_property_declarations():
    net = vgraph.load(SPHERE)
    viewer = Viewer(net, size=(48, 32), properties=["rc.sampling_rate", "rc.compositing",
                                                    "rc.empty_space_skipping", "source.resolution",
                                                    "rc.iso_level"])
    kinds = {address: type(widget) for address, widget in viewer.controls.items()}
    assert kinds == {"rc.sampling_rate": widgets.FloatLogSlider,  # 0.05 .. 16: over two decades
                     "rc.compositing": widgets.Dropdown, "rc.empty_space_skipping": widgets.Checkbox,
                     "source.resolution": widgets.IntSlider, "rc.iso_level": widgets.FloatSlider}
    assert viewer.controls["rc.compositing"].options == ("dvr", "mip", "iso", "first_hit", "xray")
    assert viewer.controls["rc.sampling_rate"].value == net.get("rc.sampling_rate")
    assert decoded(viewer.image.value).shape == (32, 48, 4)
    assert viewer.children[0] is viewer.image and viewer.children[-1] is viewer.status


def test_viewer_renders_again_when_a_widget_changes():
    net = vgraph.load(SPHERE)
    viewer = Viewer(net, size=(48, 32), properties=["rc.compositing"])
    first = viewer.image.value
    viewer.controls["rc.compositing"].value = "mip"
    assert net.get("rc.compositing") == "mip" and viewer.image.value != first
    start = net.get("eep.camera")
    viewer.azimuth.value = 90.0
    assert net.get("eep.camera") == net.get("rc.camera") == start.rotate(np.pi / 2, 0.0)
    viewer.azimuth.value = 0.0
    assert net.get("eep.camera") == start  # sliders are absolute, from the start camera


def test_an_int_property_without_a_maximum_slides_over_the_time_steps():
    net = vgraph.Network()
    net.add("StepsToy", id="toy")
    viewer = Viewer(net, size=(8, 8), target="toy.image", properties=["toy.time_step"])
    slider = viewer.controls["toy.time_step"]
    assert isinstance(slider, widgets.IntSlider) and (slider.min, slider.max) == (0, 2)
    slider.value = 2
    assert decoded(viewer.image.value)[0, 0, 0] == round(255 * 0.5)


def test_viewer_errors_show_in_the_status_line(tmp_path):
    net = vgraph.Network()
    net.add("ImageSource", id="source", path=str(tmp_path / "missing.png"))
    net.add("Canvas", id="canvas")
    net.connect("source.image", "canvas.image")
    viewer = Viewer(net, size=(16, 16))
    assert "file not found" in viewer.status.value and viewer.image.value == b""
    with pytest.raises(vgraph.PropertyError, match="source.nope: ImageSource has no property 'nope'"):
        Viewer(net, properties=["source.nope"])
    sphere = vgraph.load(SPHERE)
    with pytest.raises(vgraph.VGraphError, match="rc.camera: the Viewer has no widget for a "
                                                 "camera property"):
        Viewer(sphere, size=(16, 16), properties=["rc.camera"])


def test_a_transfer_function_is_chosen_among_the_presets_by_name():
    sphere = vgraph.load(SPHERE)
    stored = sphere.get("rc.transfer_function")
    viewer = Viewer(sphere, size=(16, 16), properties=["rc.transfer_function"])
    menu = viewer.controls["rc.transfer_function"]
    assert menu.value == stored and [label for label, _ in menu.options][:3] == ["as set", "auto", "grayscale"]
    menu.value = "hot-metal"
    assert sphere.get("rc.transfer_function") == PRESETS["hot-metal"]


def test_the_example_notebook_runs_and_shows_pictures(tmp_path):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    # Run a copy beside a link to networks/, as the notebook sits in the repository, so that
    # running it writes nothing into docs/.
    folder = tmp_path / "docs" / "notebooks"
    folder.mkdir(parents=True)
    shutil.copy(NOTEBOOK, folder)
    (tmp_path / "networks").symlink_to(REPO / "networks")
    notebook = nbformat.read(folder / NOTEBOOK.name, as_version=4)
    # kernel "python3": jupyter_client starts it with this interpreter (sys.executable), so the
    # kernel imports the vgraph under test; QT_QPA_PLATFORM=offscreen comes from conftest's env.
    client = nbclient.NotebookClient(notebook, kernel_name="python3", timeout=300,
                                     resources={"metadata": {"path": str(folder)}})
    client.execute()
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    pictures = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(pictures) >= 3  # the sphere, its MIP image, the torus with its colour bar
    assert any("application/vnd.jupyter.widget-view+json" in o.get("data", {}) for o in outputs)
