"""MultiVolumeRayCaster: several channels in one ray caster. Images against the CPU reference
(vgraph.numerics.multivolume_reference) for every blend mode with a shifted copy and a channel on another
grid; closed-form answers (a shifted channel's MIP is the first one's moved by the shift; a linear
field on another grid shows its own values at the pixels' world points); one channel equals the
RayCaster; order, gaps between the connected inports, the example network, and the errors."""

import numpy as np
import pytest

from vgraph import ProcessorError, PropertyError
from vgraph.camera import Camera
from vgraph.cli import main
from vgraph.errors import PortError
from vgraph.implicit import sample
from vgraph.numerics.multivolume_reference import render_channels
from vgraph.network import Network
from vgraph.scheduler import BlankImageWarning
from vgraph.numerics.reference_raycast import Shading, volume_box
from vgraph.testing import ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.multivolume import (BLUE, GREEN_RAMP, ORANGE, RED_RAMP, REFERENCE_TOLERANCE,
                                 assert_cut_like_the_reference, multivolume_network, oblique_camera, shifted)
from helpers.paths import DATA, REPO

SIZE = (56, 44)


def render_gl(volumes, camera, size=SIZE, output="image", **properties):
    return multivolume_network(volumes, camera, **properties).evaluate(f"mv.{output}", size=size)


def aligned_camera(volume):
    """Orthographic down -z with pixel centres on the voxel centres of ``volume``: pixel (row, col)
    sees the voxel column x = col, y = ny - 1 - row."""
    lo, hi = volume_box(volume)
    centre = (lo + hi) / 2
    return Camera(projection="orthographic", position=(centre[0], centre[1], hi[2] + 5.0),
                  focus=tuple(centre),
                  near=1.0, far=50.0, parallel_scale=volume.dims[1] * volume.spacing[1] / 2)


@pytest.fixture(scope="module")
def torus():
    return sample("torus", 28, "float32")


@pytest.fixture(scope="module")
def other_grid(torus):
    """A sphere on its own grid: coarser anisotropic spacing and an origin off the torus's."""
    data = sample("sphere", 20, "uint16").data
    return Volume(data, spacing=(0.13, 0.09, 0.11), origin=(-1.3, -0.7, -0.9))


# --- against the CPU reference ------------------------------------------------------------------
@pytest.mark.parametrize("blend", ["accumulate", "nearest_opaque", "maximum"])
def test_a_shifted_copy_matches_the_cpu_reference(torus, blend):
    channel_b = shifted(torus, (4, -3, 2))
    camera = oblique_camera(torus)
    properties = dict(blend=blend, transfer_function1=ORANGE, transfer_function2=BLUE,
                      background=(0.1, 0.2, 0.3, 1.0), opacity_threshold=0.3)
    gl = render_gl([torus, channel_b], camera, **properties)
    reference = render_channels([(torus, ORANGE), (channel_b, BLUE)], camera, SIZE, blend=blend,
                                opacity_threshold=0.3, background=(0.1, 0.2, 0.3, 1.0))
    alone = render_channels([(torus, ORANGE)], camera, SIZE, blend=blend, opacity_threshold=0.3,
                            background=(0.1, 0.2, 0.3, 1.0))
    assert np.abs(reference - alone).max() > 0.2  # the second channel shows
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


@pytest.mark.parametrize("blend, rate", [("accumulate", 1.0), ("accumulate", 2.0), ("nearest_opaque", 1.0),
                                         ("maximum", 0.7)])
def test_a_channel_on_another_grid_matches_the_cpu_reference(torus, other_grid, blend, rate):
    """Different spacing and origin; the step is the sphere's smallest spacing, so each channel's
    opacity is corrected for its own reference step."""
    camera = oblique_camera(torus)
    gl = render_gl([torus, other_grid], camera, blend=blend, sampling_rate=rate, transfer_function1=ORANGE,
                   transfer_function2=BLUE)
    reference = render_channels([(torus, ORANGE), (other_grid, BLUE)], camera, SIZE, blend=blend,
                                sampling_rate=rate)
    assert np.abs(reference - reference[0, 0]).max() > 0.3
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


GREEN = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.3, 0.2, 0.9, 0.3, 0.0), (0.55, 0.3, 1.0, 0.4, 0.5),
                                 (1.0, 0.5, 1.0, 0.5, 0.7)])
MAGENTA = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.35, 0.9, 0.2, 0.8, 0.0), (0.7, 1.0, 0.4, 0.9, 0.6),
                                   (1.0, 1.0, 0.6, 1.0, 0.6)])


@pytest.mark.parametrize("count", [3, 4])
@pytest.mark.parametrize("blend, shading", [("accumulate", "blinn_phong"), ("nearest_opaque", "none"),
                                            ("maximum", "none")])
def test_three_and_four_channels_match_the_cpu_reference(torus, other_grid, count, blend, shading):
    volumes = [torus, shifted(torus, (4, -3, 2)), other_grid, shifted(torus, (-5, 2, 0))][:count]
    tfs = [ORANGE, BLUE, GREEN, MAGENTA][:count]
    camera = oblique_camera(torus)
    properties = {f"transfer_function{n}": tf for n, tf in enumerate(tfs, start=1)}
    gl = render_gl(volumes, camera, blend=blend, shading=shading, opacity_threshold=0.3, **properties)
    channels = list(zip(volumes, tfs))
    shade = Shading() if shading != "none" else None
    reference = render_channels(channels, camera, SIZE, blend=blend, opacity_threshold=0.3, shading=shade)
    fewer = render_channels(channels[:-1], camera, SIZE, blend=blend, opacity_threshold=0.3, shading=shade)
    assert np.abs(reference - fewer).max() > 0.1  # the last channel shows
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


@pytest.mark.parametrize("blend", ["accumulate", "nearest_opaque"])
@pytest.mark.parametrize("second", ["shifted", "other_grid"])
def test_shading_matches_the_cpu_reference(torus, other_grid, blend, second):
    """Each channel shaded with its own gradient (per world unit of its own spacing)."""
    channel_b = shifted(torus, (4, -3, 2)) if second == "shifted" else other_grid
    camera = oblique_camera(torus)
    gl = render_gl([torus, channel_b], camera, blend=blend, shading="blinn_phong", opacity_threshold=0.3,
                   transfer_function1=ORANGE, transfer_function2=BLUE)
    channels = [(torus, ORANGE), (channel_b, BLUE)]
    reference = render_channels(channels, camera, SIZE, blend=blend, opacity_threshold=0.3, shading=Shading())
    unshaded = render_channels(channels, camera, SIZE, blend=blend, opacity_threshold=0.3)
    assert np.abs(reference - unshaded).max() > 0.3  # shading shows
    np.testing.assert_allclose(gl, reference, atol=REFERENCE_TOLERANCE)


def test_clip_planes_and_crop_box_of_the_entry_exit_points_cut_every_channel(torus, other_grid):
    """The rays come from EntryExitPoints: its planes and crop box cut all channels alike."""
    planes = [{"normal": [1.0, 0.3, 0.0], "point": [0.1, 0.0, 0.0]}]
    crop = (-1.0, -1.0, -0.4, 1.0, 1.0, 1.0)
    camera = oblique_camera(torus)
    network = multivolume_network([torus, other_grid], camera, transfer_function1=ORANGE,
                                  transfer_function2=BLUE, shading="blinn_phong")
    assert_cut_like_the_reference(network, [(torus, ORANGE), (other_grid, BLUE)], camera, SIZE, planes, crop)


# --- closed-form answers ------------------------------------------------------------------------
def test_maximum_of_a_shifted_copy_is_the_first_channels_mip_moved_by_the_shift():
    """Red ramp on A, green ramp on B = A moved 3 voxels along +x: green = red moved 3 pixels
    right, and nothing where B's box does not reach (a channel absent there adds nothing)."""
    data = np.random.default_rng(4).random((7, 9, 12)).astype(np.float32)
    a = Volume(data, spacing=(0.8, 0.8, 0.4), origin=(1.0, -2.0, 3.0))
    b = shifted(a, (3, 0, 0))
    nx, ny, _ = a.dims
    image = render_gl([a, b], aligned_camera(a), (nx, ny), blend="maximum", transfer_function1=RED_RAMP,
                      transfer_function2=GREEN_RAMP)
    mip = a.normalized(a.data).max(axis=0)[::-1, :]  # row 0 = largest y
    np.testing.assert_allclose(image[..., 0], mip, atol=1e-5)
    np.testing.assert_allclose(image[..., 1][:, 3:], mip[:, :-3], atol=1e-5)
    np.testing.assert_allclose(image[..., 1][:, :3], 0.0, atol=1e-7)
    np.testing.assert_allclose(image[..., 2], 0.0, atol=1e-7)


def test_a_channel_on_another_grid_shows_its_values_at_the_pixels_world_points():
    """B holds f = x + 2 y (constant along z) on a grid of another spacing and origin; trilinear
    reconstruction is exact for it, so with a green ramp each pixel's green is B's normalised f at
    the pixel's world (x, y) where B's box covers it, 0 elsewhere."""
    a = Volume(np.full((6, 10, 14), 0.0, dtype=np.float32), spacing=(0.5, 0.5, 0.5), origin=(0.0, 0.0, 0.0))
    spacing, origin = np.array([0.7, 0.3, 0.45]), np.array([1.1, 0.6, -0.4])
    ix, iy = np.arange(8) * spacing[0] + origin[0], np.arange(11) * spacing[1] + origin[1]
    field = ix[None, None, :] + 2.0 * iy[None, :, None] + np.zeros((5, 1, 1))
    b = Volume(field.astype(np.float32), spacing=tuple(spacing), origin=tuple(origin))
    nx, ny, _ = a.dims
    image = render_gl([a, b], aligned_camera(a), (nx, ny), blend="maximum", transfer_function1=RED_RAMP,
                      transfer_function2=GREEN_RAMP)
    x = a.origin[0] + np.arange(nx) * a.spacing[0]
    y = a.origin[1] + (ny - 1 - np.arange(ny)) * a.spacing[1]
    world_x, world_y = np.meshgrid(x, y)
    low, high = volume_box(b)
    covered = (world_x >= low[0]) & (world_x <= high[0]) & (world_y >= low[1]) & (world_y <= high[1])
    assert 0.2 < covered.mean() < 0.8
    expected = np.where(covered, (world_x + 2 * world_y - field.min()) / (field.max() - field.min()), 0.0)
    np.testing.assert_allclose(image[..., 1], expected, atol=1e-5)
    np.testing.assert_allclose(image[..., 0], 0.0, atol=1e-7)  # A is 0 everywhere: transparent


# --- one channel, order, gaps -------------------------------------------------------------------
@pytest.mark.parametrize("blend, compositing, rate, shading", [
    ("accumulate", "dvr", 1.0, "none"), ("accumulate", "dvr", 2.5, "none"),
    ("accumulate", "dvr", 1.0, "blinn_phong"),
    ("maximum", "mip", 1.0, "none"), ("maximum", "mip", 0.5, "none")])
def test_one_channel_equals_the_raycaster(torus, blend, compositing, rate, shading):
    camera = oblique_camera(torus)
    network = ray_caster_network(torus, camera, "RayCaster", compositing=compositing, shading=shading,
                                 transfer_function=ORANGE, sampling_rate=rate, background=(0.2, 0.1, 0.0, 1.0))
    expected = network.evaluate("rc.image", size=SIZE)
    image = render_gl([torus], camera, blend=blend, transfer_function1=ORANGE, sampling_rate=rate,
                      background=(0.2, 0.1, 0.0, 1.0), shading=shading)
    np.testing.assert_allclose(image, expected, atol=1e-6)
    expected_depth = network.evaluate("rc.depth", size=SIZE)
    depth = render_gl([torus], camera, output="depth", blend=blend, transfer_function1=ORANGE,
                      sampling_rate=rate, shading=shading)
    np.testing.assert_allclose(depth[..., [0, 1, 3]], expected_depth[..., [0, 1, 3]], atol=1e-6)


def test_accumulate_does_not_depend_on_the_order_of_the_channels(torus):
    """Mixing is symmetric (the rays span the union of the boxes, whichever channel is first)."""
    b = Volume(torus.data[:, ::-1, :].copy(), spacing=torus.spacing, origin=torus.origin)
    camera = oblique_camera(torus)
    ab = render_gl([torus, b], camera, transfer_function1=ORANGE, transfer_function2=BLUE)
    ba = render_gl([b, torus], camera, transfer_function1=BLUE, transfer_function2=ORANGE)
    np.testing.assert_allclose(ab, ba, atol=1e-6)


def test_unconnected_inports_between_channels_are_skipped(torus):
    """volume1 + volume3 (with transfer_function3) draws what volume1 + volume2 draws."""
    b = shifted(torus, (3, 0, 0))
    camera = oblique_camera(torus)
    through_2 = render_gl([torus, b], camera, transfer_function1=ORANGE, transfer_function2=BLUE)
    network = multivolume_network([torus, b], camera, ports=["volume1", "volume3"], transfer_function1=ORANGE,
                                  transfer_function3=BLUE)
    np.testing.assert_array_equal(network.evaluate("mv.image", size=SIZE), through_2)


def test_nearest_opaque_depth_marks_the_hits(torus):
    camera = oblique_camera(torus)
    network = multivolume_network([torus, shifted(torus, (5, 0, 0))], camera, blend="nearest_opaque",
                                  transfer_function1=ORANGE, transfer_function2=BLUE, opacity_threshold=0.3)
    image = network.evaluate("mv.image", size=SIZE)
    depth = network.evaluate("mv.depth", size=SIZE)
    hit = np.any(image[..., :3] != 0.0, axis=-1)  # black background: a hit has a TF colour
    assert 0.1 < hit.mean() < 0.9
    np.testing.assert_array_equal(depth[..., 3] == 1.0, hit)
    assert np.all((depth[hit, 0] > 0.0) & (depth[hit, 0] < 1.0))


def test_an_empty_picture_of_visible_channels_is_warned_about(torus):
    """The scheduler's blank-image warning: the camera looks away from the volumes."""
    away = Camera(position=(0.0, 0.0, 5.0), focus=(0.0, 0.0, 9.0), near=0.1, far=3.0)
    network = multivolume_network([torus, shifted(torus, (3, 0, 0))], away, transfer_function1=ORANGE,
                                  transfer_function2=BLUE)
    with pytest.warns(BlankImageWarning, match=r"mv \(MultiVolumeRayCaster\).*volume1: .*volume2: "):
        network.evaluate("mv.image", size=SIZE)


# --- errors -------------------------------------------------------------------------------------
def test_a_fifth_channel_is_refused_with_the_inports_named():
    network = Network()
    network.add("FunctionSelector", id="f")
    network.add("MultiVolumeRayCaster", id="mv")
    with pytest.raises(PortError, match="volume5"):
        network.connect("f.volume", "mv.volume5")


def test_a_channel_without_a_transfer_function_is_refused():
    network = Network()
    network.add("MultiVolumeRayCaster", id="mv")
    with pytest.raises(PropertyError, match="mv.transfer_function2"):
        network.set("mv.transfer_function2", None)
    with pytest.raises(PropertyError, match="transfer_function3"):
        network.add("MultiVolumeRayCaster", id="mv2", transfer_function3="no-such-preset")


def test_the_first_volume_is_required(torus):
    network = multivolume_network([torus, torus], oblique_camera(torus))
    network.disconnect("src1.volume", "mv.volume1")
    with pytest.raises(ProcessorError, match="volume1"):
        network.evaluate("mv.image", size=SIZE)


def test_spline_coefficients_are_refused_naming_the_channel(torus):
    coefficients = Volume(torus.data, is_spline_coefficients=True)
    with pytest.raises(ProcessorError, match=r"volume2.*B-spline coefficients"):
        render_gl([torus, coefficients], oblique_camera(torus))


def test_a_channel_too_large_for_one_texture_is_refused_naming_it(torus, monkeypatch):
    """(A volume wider than the GL's 3D-texture limit would take gigabytes here: the test makes the
    second channel count as one.)"""
    import vgraph.processors.multi_volume_raycaster as module
    big = shifted(torus, (1, 0, 0))
    monkeypatch.setattr(module, "needs_bricks", lambda volume, ctx: volume is big)
    with pytest.raises(ProcessorError, match=r"mv.volume2: .*does not fit one GL 3D texture"):
        render_gl([torus, big], oblique_camera(torus))


# --- the example network ------------------------------------------------------------------------
def test_the_hydrogen_neghip_network_renders_both_channels_from_the_cli(tmp_path):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    network = REPO / "networks" / "two_channels_hydrogen_neghip.json"
    out = tmp_path / "image.npy"
    assert main(["run", str(network), "--size", "96x80", "--npy", str(out),
                 "-o", str(tmp_path / "image.png")]) == 0
    image = np.load(out)
    assert image.shape == (80, 96, 4) and np.isfinite(image).all()
    drawn = image[..., :3].max(axis=-1) > 0.02
    assert drawn.mean() > 0.1 and drawn[20:60, 24:72].mean() > drawn.mean()
    np.testing.assert_allclose(image[[0, 0, -1, -1], [0, -1, 0, -1], :3], 0.0, atol=1e-6)
    # Both hues are there: hydrogen orange (red > blue), neghip blue (blue > red).
    assert ((image[..., 0] > image[..., 2] + 0.1) & drawn).mean() > 0.01
    assert ((image[..., 2] > image[..., 0] + 0.1) & drawn).mean() > 0.01


def test_the_gui_shows_the_network_and_switches_the_blend_mode(window, jobs):
    """Opened in the GUI: the inspector has an editor per channel's TF, and a blend picked there
    gives on the canvas exactly the CLI's picture of that blend."""
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    import vgraph
    from vgraph.imagefile import to_uint8
    path = REPO / "networks" / "two_channels_hydrogen_neghip.json"
    assert window.open_network(path)
    assert not window.evaluation.run(wait=True).failed
    window.scene.select_processor("mv")
    assert {f"transfer_function{n}" for n in range(1, 5)} <= set(window.inspector.editors)
    window.inspector.editors["blend"].combo.setCurrentText("maximum")
    outcome = window.evaluation.run(wait=True)
    assert not outcome.failed and "canvas" in outcome.frames
    view = window.canvases.views["canvas"]
    assert view.is_final
    network = vgraph.load(path)
    network.set("mv.blend", "maximum")
    np.testing.assert_array_equal(view.frame(), to_uint8(network.evaluate("canvas")))


# --- the TF editors in the GUI ------------------------------------------------------------------
def test_each_transfer_function_is_paired_with_its_channels_volume_for_the_editors(torus, other_grid):
    """live.evaluator gives each TF property the histogram and value scale of the volume it
    classifies (the MultiVolumeRayCaster's declared pairing); a RayCaster's single TF keeps its
    volume's; a TF whose channel is not connected gets none."""
    from vgraph.live.evaluator import histograms, value_scales
    from vgraph.processors.multi_volume_raycaster import MultiVolumeRayCaster
    from vgraph.testing import ray_caster_network
    from vgraph.transfer_function import ValueScale
    pairing = MultiVolumeRayCaster.transfer_function_inports
    assert set(pairing) == {f"transfer_function{n}" for n in range(1, 5)}
    assert set(pairing.values()) <= {port.name for port in MultiVolumeRayCaster.inports}
    network = multivolume_network([torus, other_grid], oblique_camera(torus))
    network.evaluate("mv.image", size=SIZE)
    counts, scales = histograms(network), value_scales(network)
    np.testing.assert_array_equal(counts["mv.transfer_function1"], torus.histogram()[0])
    np.testing.assert_array_equal(counts["mv.transfer_function2"], other_grid.histogram()[0])
    assert not np.array_equal(counts["mv.transfer_function1"], counts["mv.transfer_function2"])
    assert scales["mv.transfer_function2"] == ValueScale.of(other_grid) != scales["mv.transfer_function1"]
    assert "mv.transfer_function3" not in counts and "mv.transfer_function3" not in scales
    np.testing.assert_array_equal(counts["mv"], torus.histogram()[0])  # the processor's first volume
    single = ray_caster_network(other_grid, oblique_camera(other_grid))
    single.evaluate("rc.image", size=SIZE)
    np.testing.assert_array_equal(histograms(single)["rc.transfer_function"], other_grid.histogram()[0])
    assert value_scales(single)["rc.transfer_function"] == ValueScale.of(other_grid)


def test_the_gui_editor_of_transfer_function2_shows_volume2s_histogram_and_values(window, jobs, tmp_path):
    """Two channels of different values (uint8 0..40 and float32 500..3000) from files: in the
    inspector, transfer_function2's editor plots volume2's histogram over volume2's value range,
    transfer_function1's volume1's, and transfer_function3's (no channel) none."""
    import vgraph
    from vgraph.transfer_function import ValueScale
    rng = np.random.default_rng(3)
    np.save(tmp_path / "one.npy", rng.integers(0, 41, (12, 14, 16)).astype(np.uint8))
    np.save(tmp_path / "two.npy", (500.0 + 2500.0 * rng.random((10, 12, 9)) ** 3).astype(np.float32))
    network = Network(base_dir=tmp_path)
    network.add("VolumeSource", id="one", path="one.npy")
    network.add("VolumeSource", id="two", path="two.npy")
    network.add("EntryExitPoints", id="eep")
    network.add("MultiVolumeRayCaster", id="mv")
    network.add("Canvas", id="canvas", size=(32, 32))
    network.link("eep.camera", "mv.camera")
    for source, target in [("one.volume", "eep.volume"), ("two.volume", "eep.volume2"),
                           ("one.volume", "mv.volume1"), ("two.volume", "mv.volume2"),
                           ("eep.entry", "mv.entry"), ("eep.exit", "mv.exit"), ("mv.image", "canvas.image")]:
        network.connect(source, target)
    path = tmp_path / "channels.json"
    network.save(path)
    assert window.open_network(path)
    assert not window.evaluation.run(wait=True).failed
    window.scene.select_processor("mv")
    editors = window.inspector.editors
    local = vgraph.load(path)
    local.evaluate("canvas")
    volumes = {n: local[source].outputs["volume"] for n, source in ((1, "one"), (2, "two"))}
    for n, volume in volumes.items():
        plot = editors[f"transfer_function{n}"].plot
        np.testing.assert_array_equal(plot.counts, volume.histogram()[0])
        assert plot.scale == ValueScale.of(volume)
    assert editors["transfer_function2"].plot.scale.value_range[0] >= 500.0  # volume2's, not volume1's
    assert editors["transfer_function3"].plot.counts is None and editors["transfer_function3"].plot.scale is None
