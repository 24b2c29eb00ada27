"""Gradient opacity and 2D transfer functions (issue 37 item 1): the models (vgraph.gradient_opacity,
vgraph.transfer_function_2d), the RayCaster's images against the CPU reference's classification
(vgraph.numerics.reference_classification), errors that name the processor and field, the .json
round trip, and that nothing changes while both are off."""

import json

import numpy as np
import pytest

from vgraph import ProcessorError, PropertyError
from vgraph.camera import Camera
from vgraph.fileformat import load_network
from vgraph.gl.raycasting.gradient_classification import largest_magnitude
from vgraph.gl.raycasting.gradient_volume import is_cached
from vgraph.gradient_opacity import GradientOpacity, PRESETS as CURVES
from vgraph.network import Network
from vgraph.numerics.reference_classification import GradientClassification, largest_gradient_magnitude
from vgraph.numerics.reference_raycast import Shading, VolumeSampler, render, volume_box
from vgraph.scheduler import BlankImageWarning
from vgraph.transfer_function import TransferFunction
from vgraph.transfer_function_2d import (PRESETS as TABLES, Gaussian, Rectangle, TransferFunction2D, Triangle,
                                         new_primitive)
from vgraph.volume import Volume

from helpers.networks import rendering_network

# Max |GL - reference| per channel, measured on llvmpipe: 1.1e-6 with gradient opacity (as the 1D
# TF alone), 1.1e-5 with a 2D TF (its triangles and rectangles step by up to 0.8 from one texel
# to the next, so a float rounding of the texture coordinate shows more); a few times that.
CURVE_TOLERANCE = 1e-5
TABLE_TOLERANCE = 5e-5
# Faint enough that rays reach the blobs' centres (small gradients) before they stop.
COLOURED = TransferFunction(points=[(0.0, 0, 0, 0, 0), (0.2, 0.2, 0.4, 0.9, 0.0),
                                    (0.5, 1.0, 0.7, 0.2, 0.06), (1.0, 1, 1, 1, 0.15)])
# Opaque where the gradient is small (inside the blobs), transparent at their boundaries: the
# opposite of the preset, so the image must differ from the TF alone.
INTERIOR = GradientOpacity(points=[(0.0, 1.0), (0.3, 1.0), (0.6, 0.0), (1.0, 0.0)])
SIZE = (48, 40)
BACKGROUND = (0.1, 0.2, 0.3, 1.0)


@pytest.fixture(scope="module")
def blobs():
    """Two Gaussian blobs of different heights: values 0..1 with every gradient from 0 (at the
    centres and far away) to the largest (on their flanks), anisotropic spacing."""
    z, y, x = np.meshgrid(*(np.linspace(-1.0, 1.0, n) for n in (20, 24, 28)), indexing="ij")
    data = (np.exp(-((x + 0.35) ** 2 + y ** 2 + z ** 2) / 0.12)
            + 0.55 * np.exp(-((x - 0.45) ** 2 + (y - 0.2) ** 2 + z ** 2) / 0.08))
    return Volume(data.astype(np.float32), spacing=(0.9, 1.0, 1.2), origin=(-3.0, 1.0, 2.0))


def camera_of(volume):
    return Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))


def gl_image(volume, output="image", **properties):
    network = rendering_network(volume, camera_of(volume), transfer_function=COLOURED,
                                background=BACKGROUND, **properties)
    return network.evaluate(f"rc.{output}", size=SIZE), network


def reference_image(volume, shaded=False, **classification):
    return render(volume, camera_of(volume), COLOURED, SIZE, background=BACKGROUND,
                  shading=Shading(gradients="precomputed") if shaded else None,
                  classification=GradientClassification(**classification))


# --- the models ---------------------------------------------------------------------------------
def test_the_curve_interpolates_between_its_points_and_holds_its_ends():
    curve = GradientOpacity(points=[(0.2, 0.0), (0.6, 1.0)])
    np.testing.assert_allclose(curve([0.0, 0.2, 0.4, 0.6, 1.0, 7.0]), [0.0, 0.0, 0.5, 1.0, 1.0, 1.0])
    assert curve.lut()[0] == 0.0 and curve.lut()[-1] == 1.0 and len(curve.lut()) == 1024


def test_primitives_cover_what_they_say():
    rectangle = Rectangle(value=(0.2, 0.4), gradient=(0.0, 0.5), color=(1.0, 0.0, 0.0, 0.5))
    triangle = Triangle(vertices=((0.5, 0.0), (0.3, 1.0), (0.7, 1.0)), color=(0.0, 1.0, 0.0, 0.8))
    gaussian = Gaussian(centre=(0.5, 0.5), width=(0.1, 0.2), color=(0.0, 0.0, 1.0, 0.6))
    np.testing.assert_allclose(rectangle.alpha(np.array([0.2, 0.3, 0.4, 0.41, 0.3]),
                                               np.array([0.0, 0.5, 0.2, 0.2, 0.51])), [0.5, 0.5, 0.5, 0, 0])
    # The triangle at gradient 0.5 spans values 0.4 .. 0.6.
    np.testing.assert_allclose(triangle.alpha(np.array([0.39, 0.4, 0.5, 0.6, 0.61]), 0.5), [0, 0.8, 0.8, 0.8, 0])
    assert gaussian.alpha(np.array(0.6), np.array(0.7)) == pytest.approx(0.6 * np.exp(-0.5 * (1.0 + 1.0)))
    assert gaussian.alpha(np.array(0.5), np.array(0.5 + 0.59)) == pytest.approx(0.6 * np.exp(-0.5 * 2.95 ** 2))
    assert gaussian.alpha(np.array(0.5), np.array(0.5 + 0.61)) == 0.0  # cut beyond 3 widths


def test_overlapping_primitives_combine_as_independent_absorbers_in_any_order():
    red = Rectangle(value=(0.0, 1.0), gradient=(0.0, 1.0), color=(1.0, 0.0, 0.0, 0.5))
    blue = Rectangle(value=(0.5, 1.0), gradient=(0.0, 1.0), color=(0.0, 0.0, 1.0, 0.25))
    for order in ([red, blue], [blue, red]):
        rgba = TransferFunction2D(primitives=order)(np.array([0.25, 0.75]), 0.5)
        np.testing.assert_allclose(rgba[0], [1.0, 0.0, 0.0, 0.5])
        np.testing.assert_allclose(rgba[1], [0.5 / 0.75, 0.0, 0.25 / 0.75, 1.0 - 0.5 * 0.75])


@pytest.mark.parametrize("kind", ["rectangle", "triangle", "gaussian"])
def test_new_primitives_cover_their_place_and_moves_keep_them_in_the_plane(kind):
    primitive = new_primitive(kind, 0.95, 0.02)  # near a corner: moved inside
    corners = np.asarray(primitive.corners())
    assert corners.min() >= 0.0 and corners.max() <= 1.0 and primitive.covers(*corners.mean(axis=0))
    moved = primitive.moved(-5.0, 0.25)
    shifted = np.asarray(moved.corners()) - corners
    assert np.asarray(moved.corners())[:, 0].min() == 0.0  # cut at the plane's edge ...
    np.testing.assert_allclose(shifted, np.broadcast_to(shifted[0], shifted.shape), atol=1e-12)  # ... whole
    assert shifted[0, 1] == pytest.approx(0.25)
    with pytest.raises(ValueError, match="one of rectangle, triangle, gaussian"):
        new_primitive("circle", 0.5, 0.5)


def test_handles_reshape_primitives_and_never_make_them_invalid():
    rectangle = new_primitive("rectangle", 0.5, 0.5)
    assert rectangle.with_handle(1, 0.8, 0.9).value == (0.4, 0.8)
    assert rectangle.with_handle(0, 0.9, 0.1).value == (0.6, 0.6)  # the low corner stops at the high one
    triangle = new_primitive("triangle", 0.5, 0.5)
    assert triangle.with_handle(0, 0.5, 0.2).vertices[0] == (0.5, 0.2)
    assert triangle.with_handle(0, 0.5, 0.6) is triangle  # onto the line of the others: unchanged
    gaussian = new_primitive("gaussian", 0.5, 0.5)
    assert gaussian.with_handle(1, 0.7, 0.5).width == pytest.approx((0.2, 1e-3))
    assert gaussian.with_handle(0, 2.0, -1.0).centre == (1.0, 0.0)  # clamped to the plane


def test_the_table_is_indexed_gradient_then_value_and_premultiplied():
    table = TransferFunction2D(primitives=[Rectangle(value=(0.0, 1.0), gradient=(0.9, 1.0),
                                                     color=(1.0, 0.5, 0.0, 0.5))]).lut()
    assert table.shape == (256, 256, 4)
    assert table[-1, :, 3].min() == 0.5 and table[0, :, 3].max() == 0.0
    np.testing.assert_allclose(table[-1, 7], [0.5, 0.25, 0.0, 0.5])  # (a r, a g, a b, a)


# --- against the CPU reference ------------------------------------------------------------------
@pytest.mark.parametrize("shaded", [False, True])
@pytest.mark.parametrize("curve", ["interior", "boundaries"])
def test_gradient_opacity_matches_the_cpu_reference(blobs, curve, shaded):
    model = INTERIOR if curve == "interior" else CURVES[curve]
    shading = dict(shading="blinn_phong", derivatives="precomputed") if shaded else {}
    gl, _ = gl_image(blobs, gradient_opacity=model, **shading)
    reference = reference_image(blobs, shaded, gradient_opacity=model)
    without = reference_image(blobs, shaded)
    assert np.abs(reference - without).max() > 0.01  # the curve changes the picture
    np.testing.assert_allclose(gl, reference, atol=CURVE_TOLERANCE)


@pytest.mark.parametrize("shaded", [False, True])
@pytest.mark.parametrize("preset", list(TABLES))
def test_2d_transfer_function_matches_the_cpu_reference(blobs, preset, shaded):
    shading = dict(shading="blinn_phong", derivatives="precomputed") if shaded else {}
    gl, _ = gl_image(blobs, transfer_function_2d=preset, **shading)
    reference = reference_image(blobs, shaded, transfer_function_2d=TABLES[preset])
    assert np.abs(reference - reference[0, 0]).max() > 0.2  # the blobs are in the picture
    assert np.abs(reference - reference_image(blobs, shaded)).max() > 0.1  # not the 1D TF's
    np.testing.assert_allclose(gl, reference, atol=TABLE_TOLERANCE)


def test_both_together_match_the_cpu_reference(blobs):
    gl, _ = gl_image(blobs, transfer_function_2d="two-materials", gradient_opacity=INTERIOR)
    reference = reference_image(blobs, transfer_function_2d=TABLES["two-materials"], gradient_opacity=INTERIOR)
    np.testing.assert_allclose(gl, reference, atol=TABLE_TOLERANCE)


@pytest.mark.parametrize("kind", ["uint8", "oriented"])
def test_integer_and_oriented_volumes_match_the_cpu_reference(blobs, kind):
    """uint8, shaded: the gradient texture also holds the value (GRADIENT_HOLDS_VALUE); oriented:
    the gradient turns with the volume, its magnitude does not."""
    if kind == "uint8":
        volume = Volume((blobs.data / blobs.data.max() * 255).astype(np.uint8), spacing=blobs.spacing,
                        origin=blobs.origin)
    else:
        volume = Volume(blobs.data, spacing=blobs.spacing, origin=blobs.origin,
                        direction=np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
    gl, _ = gl_image(volume, shading="blinn_phong", derivatives="precomputed",
                     transfer_function_2d="two-materials", gradient_opacity=INTERIOR)
    reference = reference_image(volume, True, transfer_function_2d=TABLES["two-materials"],
                                gradient_opacity=INTERIOR)
    assert np.abs(reference - reference[0, 0]).max() > 0.05  # faint (the curve hides the boundaries), not empty
    np.testing.assert_allclose(gl, reference, atol=TABLE_TOLERANCE)


def test_the_largest_gradient_is_the_references(blobs):
    assert largest_magnitude(blobs) == pytest.approx(largest_gradient_magnitude(VolumeSampler(blobs)), rel=1e-12)


@pytest.mark.parametrize("properties", [dict(transfer_function_2d="two-materials"),
                                        dict(gradient_opacity=INTERIOR)])
def test_empty_space_skipping_changes_no_pixel(blobs, properties):
    skipped, network = gl_image(blobs, empty_space_skipping=True, **properties)
    assert network["rc"].passes[-1].defines["SKIP_EMPTY_SPACE"]  # some blocks are empty
    plain, _ = gl_image(blobs, empty_space_skipping=False, **properties)
    np.testing.assert_array_equal(skipped, plain)


def test_nothing_visible_in_the_2d_tf_shows_the_background_in_dvr_and_first_hit(blobs):
    nothing = TransferFunction2D(primitives=[Rectangle(value=(0.0, 1.0), gradient=(0.0, 1.0),
                                                       color=(1.0, 1.0, 1.0, 0.0))])
    for compositing in ("dvr", "first_hit"):
        with pytest.warns(BlankImageWarning, match=r"rendered an empty image: rc.transfer_function_2d shows "
                                                   r"nothing of its volume"):
            image, _ = gl_image(blobs, compositing=compositing, transfer_function_2d=nothing)
        np.testing.assert_allclose(image, np.broadcast_to(BACKGROUND, image.shape), atol=1e-7)


# --- off by default -----------------------------------------------------------------------------
def test_off_builds_no_gradient_volume_and_compiles_no_classification(blobs):
    volume = Volume(blobs.data.copy(), spacing=blobs.spacing)
    _, network = gl_image(volume)
    defines = network["rc"].passes[-1].defines
    assert not {"GRADIENT_OPACITY", "TRANSFER_FUNCTION_2D"} & set(defines)
    assert not is_cached(volume)
    network.set("rc.gradient_opacity", "boundaries")
    network.evaluate("rc.image", size=SIZE)
    assert network["rc"].passes[-1].defines["GRADIENT_OPACITY"] and is_cached(volume)


# --- errors ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("primitive, reason", [
    ({"kind": "rectangle", "value": [0.6, 0.2], "gradient": [0, 1], "color": [1, 1, 1, 1]}, "low <= high"),
    ({"kind": "triangle", "vertices": [[0, 0], [0.5, 0.5], [1, 1]], "color": [1, 1, 1, 1]}, "on one line"),
    ({"kind": "gaussian", "centre": [0.5, 0.5], "width": [0.0, 0.1], "color": [1, 1, 1, 1]}, "width"),
    ({"kind": "circle", "centre": [0.5, 0.5], "color": [1, 1, 1, 1]}, "circle"),
    ({"kind": "rectangle", "value": [0, 1], "gradient": [0, 1], "color": [1, 1, 1, 2]}, "color.3"),
])
def test_a_bad_primitive_is_refused_naming_processor_field_and_primitive(blobs, primitive, reason):
    network = rendering_network(blobs, camera_of(blobs))
    with pytest.raises(PropertyError) as error:
        network.set("rc.transfer_function_2d", {"primitives": [primitive]})
    message = str(error.value)
    assert message.startswith("rc.transfer_function_2d:") and "primitives.0" in message and reason in message


def test_unknown_presets_are_refused_listing_the_known_ones(blobs):
    network = rendering_network(blobs, camera_of(blobs))
    with pytest.raises(PropertyError, match=r"rc.gradient_opacity: .*'edges' is not a gradient-opacity "
                                            r"preset \(boundaries, strong-edges\)"):
        network.set("rc.gradient_opacity", "edges")
    with pytest.raises(PropertyError, match=r"rc.transfer_function_2d: .*two-materials"):
        network.set("rc.transfer_function_2d", "arches")


@pytest.mark.parametrize("compositing", ["mip", "iso", "xray"])
def test_modes_that_classify_no_samples_refuse_it_by_name(blobs, compositing):
    network = rendering_network(blobs, camera_of(blobs), compositing=compositing, gradient_opacity="boundaries")
    with pytest.raises(ProcessorError, match=rf"rc.gradient_opacity: .*compositing {compositing} .*dvr or first_hit"):
        network.evaluate("rc.image", size=SIZE)


# --- the network file ---------------------------------------------------------------------------
def test_the_network_file_keeps_both_and_renders_the_same(tmp_path):
    network = Network()
    network.add("FunctionSelector", id="source", function="torus", resolution=24)
    network.add("EntryExitPoints", id="eep")
    network.add("RayCaster", id="rc", gradient_opacity="strong-edges", transfer_function_2d="two-materials")
    network.link("eep.camera", "rc.camera")
    for source, target in (("source.volume", "eep.volume"), ("source.volume", "rc.volume"),
                           ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit")):
        network.connect(source, target)
    path = tmp_path / "classified.json"
    network.save(path)
    saved = json.loads(path.read_text())["processors"]
    [entry] = [p for p in saved if p["id"] == "rc"]
    assert entry["properties"]["transfer_function_2d"]["primitives"][0]["kind"] == "triangle"
    loaded = load_network(path)
    assert loaded["rc"].transfer_function_2d == TABLES["two-materials"]
    assert loaded["rc"].gradient_opacity == CURVES["strong-edges"]
    np.testing.assert_array_equal(loaded.evaluate("rc.image", size=(32, 24)), network.evaluate("rc.image", size=(32, 24)))


def test_a_network_file_with_a_bad_primitive_names_file_processor_and_primitive(tmp_path):
    from vgraph.errors import NetworkFileError
    network = Network()
    network.add("FunctionSelector", id="source", function="torus", resolution=16)
    network.add("RayCaster", id="rc", transfer_function_2d="two-materials")
    path = tmp_path / "bad.json"
    network.save(path)
    text = json.loads(path.read_text())
    [entry] = [p for p in text["processors"] if p["id"] == "rc"]
    entry["properties"]["transfer_function_2d"]["primitives"][1]["vertices"] = [[0, 0], [0.5, 0.5], [1, 1]]
    path.write_text(json.dumps(text))
    with pytest.raises(NetworkFileError) as error:
        load_network(path)
    message = str(error.value)
    assert "bad.json" in message and "transfer_function_2d" in message and "primitives.1" in message
    assert "on one line" in message
