"""The segmentation processors (VolumeMorphology, ConnectedComponents, GradientMagnitude, VolumeMath,
VolumeMask) against their reference libraries (scipy.ndimage, scikit-image, numpy) on the shared
CT head (headsq: 64 x 64 x 93 int16, spacing 3.2 x 3.2 x 1.5 mm, anisotropic), sizes in world
units, grids compared, bad values named; and networks/segment_engine.json rendered. Tolerance for
float32 results: 1e-5 of the largest |value| (float32 keeps 6e-8 a step; a gradient sums three
squares of differences)."""

import json

import numpy as np
import pytest
from scipy import ndimage
from skimage.measure import label as skimage_label

from helpers.headsq import TILT, read_head
from vgraph import Network, ProcessorError, PropertyError, VGraphError
from vgraph.registry import registry
from vgraph.volume import Volume
from vgraph.volume_segmentation import GridMismatchError



@pytest.fixture(scope="module")
def head():
    return read_head()


@pytest.fixture(scope="module")
def bone(head):
    """The head's mask above the bone level of the VTK example (1150), flagged as labels."""
    return head.with_data((head.data >= 1150).astype(np.uint8), holds_labels=True, declared_range=(0.0, 1.0))


def run(type_name, volume=None, **properties):
    inputs = {k: properties.pop(k) for k in ("first", "second", "labels") if k in properties}
    if volume is not None:
        inputs["volume"] = volume
    return registry.get(type_name)("f", **properties).process(**inputs)


def assert_close(ours, reference, relative=1e-5):
    assert ours.shape == reference.shape
    tolerance = relative * max(1.0, float(np.abs(reference).max()))
    assert np.abs(ours.astype(np.float64) - reference).max() <= tolerance


def world_ball(radius, spacing):
    """The ball of ``radius`` world units as voxel offsets [z, y, x], by its definition."""
    reach = [int(radius // s) for s in spacing[::-1]]
    offsets = np.indices([2 * r + 1 for r in reach]) - np.array(reach)[:, None, None, None]
    world = offsets * np.array(spacing[::-1])[:, None, None, None]
    return (world ** 2).sum(axis=0) <= radius ** 2 + 1e-9


def mirrored(operation, data, ball, pad):
    """``operation`` on the volume mirrored ``pad`` voxels beyond each face (numpy 'symmetric' is
    scipy's 'reflect'), cut back: the reference for filters that mirror at the faces."""
    padded = np.pad(data, pad, mode="symmetric")
    return operation(padded, ball)[tuple(slice(pad, -pad) for _ in range(3))]


# --- VolumeMorphology ---------------------------------------------------------------------------
def test_a_world_ball_is_an_ellipsoid_of_voxels_on_anisotropic_spacing():
    impulse = np.zeros((15, 9, 9), dtype=np.uint8)
    impulse[7, 4, 4] = 1
    volume = Volume(impulse, spacing=(3.2, 3.2, 1.5), holds_labels=True)
    grown = run("VolumeMorphology", volume, radius=4.8).data
    # 4.8 world units reach 1 voxel along x and y (3.2) and 3 along z (1.5)
    assert np.array_equal(np.nonzero(grown.any(axis=(1, 2)))[0], np.arange(4, 11))
    assert np.array_equal(np.nonzero(grown.any(axis=(0, 1)))[0], np.arange(3, 6))
    ball = world_ball(4.8, (3.2, 3.2, 1.5))
    assert ball.shape == (7, 3, 3) and np.array_equal(grown[4:11, 3:6, 3:6], ball)
    assert grown.sum() == ball.sum() < 7 * 3 * 3  # a ball, not a box


@pytest.mark.parametrize("operation", ["dilate", "erode", "open", "close"])
def test_grey_morphology_equals_scipy_with_the_world_ball(head, operation):
    ball = world_ball(6.0, head.spacing)  # reaches 1, 1, 4 voxels along x, y, z
    reference = {"dilate": ndimage.grey_dilation, "erode": ndimage.grey_erosion,
                 "open": ndimage.grey_opening, "close": ndimage.grey_closing}[operation](head.data, footprint=ball)
    result = run("VolumeMorphology", head, operation=operation, radius=6.0)
    assert result.data.dtype == np.int16 and np.array_equal(result.data, reference)
    assert result.value_range == head.value_range and np.array_equal(result.affine, head.affine)


@pytest.mark.parametrize("operation", ["dilate", "erode", "open", "close"])
def test_mask_morphology_equals_scipy_binary_morphology(bone, operation):
    ball = world_ball(5.0, bone.spacing)
    binary = {"dilate": ndimage.binary_dilation, "erode": ndimage.binary_erosion,
              "open": ndimage.binary_opening, "close": ndimage.binary_closing}[operation]
    reference = mirrored(lambda data, b: binary(data, structure=b), bone.data.astype(bool), ball, 8)
    result = run("VolumeMorphology", bone, operation=operation, radius=5.0)
    assert result.holds_labels and result.data.dtype == np.uint8
    assert np.array_equal(result.data, reference)
    assert (result.data != bone.data).sum() > 100  # the operation did something here


def test_label_morphology_grows_into_the_background_and_shrinks_each_label_alone(head):
    labels = head.with_data(np.digitize(head.data, [500, 1150]).astype(np.uint8), holds_labels=True)
    ball = world_ball(4.0, head.spacing)
    eroded = run("VolumeMorphology", labels, operation="erode", radius=4.0).data
    expected = sum(value * mirrored(lambda d, b: ndimage.binary_erosion(d, structure=b), labels.data == value, ball, 6)
                   for value in (1, 2))
    assert np.array_equal(eroded, expected)
    dilated = run("VolumeMorphology", labels, operation="dilate", radius=4.0).data
    expected = labels.data.copy()
    for value in (1, 2):  # a background voxel takes the largest label reaching it
        reached = mirrored(lambda d, b: ndimage.binary_dilation(d, structure=b), labels.data == value, ball, 6)
        expected[(labels.data == 0) & reached] = value
    assert np.array_equal(dilated, expected)
    assert set(np.unique(dilated)) == {0, 1, 2}  # labels never mix into new ones


def test_bad_morphology_radii_are_named(head):
    with pytest.raises(PropertyError, match=r"^f\.radius: must be above 0, got 0"):
        run("VolumeMorphology", head, radius=0.0)
    with pytest.raises(PropertyError, match=r"^f\.radius: invalid value -1\.0"):
        run("VolumeMorphology", head, radius=-1.0)
    with pytest.raises(PropertyError, match=r"^f\.radius: the ball reaches 93 voxels along x, more than "
                                            r"the volume's 64 voxels there"):
        run("VolumeMorphology", head, radius=300.0)


# --- ConnectedComponents ------------------------------------------------------------------------
@pytest.mark.parametrize("connectivity, rank", [(6, 1), (18, 2), (26, 3)])
def test_components_equal_scipy_and_scikit_image_largest_first(bone, connectivity, rank):
    result = run("ConnectedComponents", bone, connectivity=connectivity)
    reference, count = ndimage.label(bone.data, structure=ndimage.generate_binary_structure(3, rank))
    assert result.holds_labels and result.component_count == count == skimage_label(bone.data, connectivity=rank).max()
    # the same parts: each of scipy's components is exactly one of ours
    pairs = np.unique(np.stack([reference.ravel(), result.data.ravel()]), axis=1)
    assert pairs.shape[1] == count + 1 and np.array_equal(np.unique(pairs[0]), np.unique(pairs[1]))
    sizes = np.bincount(result.data.ravel())[1:]
    assert np.array_equal(result.voxel_counts, sizes) and np.all(np.diff(sizes) <= 0)  # largest first
    assert np.array_equal(np.sort(sizes), np.sort(np.bincount(reference.ravel())[1:]))
    assert np.allclose(result.world_volumes, sizes * 3.2 * 3.2 * 1.5)
    assert np.array_equal(result.affine, bone.affine) and result.value_range == (0.0, float(count))


def test_connectivity_changes_the_count_and_min_size_drops_small_parts(bone):
    counts = [run("ConnectedComponents", bone, connectivity=c).component_count for c in (6, 18, 26)]
    assert counts[0] > counts[1] > counts[2] > 1
    all_parts = run("ConnectedComponents", bone)
    kept = run("ConnectedComponents", bone, min_size=200.0)  # 200 mm^3: 14 voxels of 15.36 mm^3
    assert kept.component_count == (all_parts.world_volumes >= 200.0).sum() < all_parts.component_count
    assert np.array_equal(kept.voxel_counts, all_parts.voxel_counts[all_parts.voxel_counts >= 14])
    big = np.isin(all_parts.data, np.arange(1, kept.component_count + 1))
    assert np.array_equal(kept.data, np.where(big, all_parts.data, 0))


def test_many_components_take_a_wider_type_and_too_many_for_the_label_ray_caster_are_named(monkeypatch):
    checkers = (np.indices((16, 16, 16)).sum(axis=0) % 2).astype(np.uint8)  # touching by corners only
    many = run("ConnectedComponents", Volume(checkers, holds_labels=True), connectivity=6)
    assert many.component_count == 2048 and many.data.dtype == np.uint16 and np.all(many.voxel_counts == 1)
    assert run("ConnectedComponents", Volume(checkers), connectivity=18).component_count == 1
    from vgraph import volume_segmentation
    from vgraph.processors.label_raycaster import LABEL_ROW
    assert volume_segmentation.MAX_SHOWN_LABELS == LABEL_ROW * 16384  # GL 4.5's least GL_MAX_TEXTURE_SIZE
    monkeypatch.setattr(volume_segmentation, "MAX_SHOWN_LABELS", 1000)
    with pytest.raises(PropertyError, match=r"^f\.min_size: 2048 components of the volume \(of 2048 found\) are "
                                            r"more labels than the LabelRayCaster can show \(1000\): raise min_size"):
        run("ConnectedComponents", Volume(checkers), connectivity=6)
    with pytest.raises(PropertyError, match=r"^f\.connectivity: invalid value 8: must be 6, 18 or 26$"):
        run("ConnectedComponents", Volume(checkers), connectivity=8)


def test_components_of_intensities_are_refused(head):
    smooth = head.with_data(head.data / 7.0)
    with pytest.raises(VGraphError, match=r"ConnectedComponents 'f': .*holds intensities, not labels or a mask"):
        run("ConnectedComponents", smooth)


# --- GradientMagnitude --------------------------------------------------------------------------
def test_central_differences_equal_numpy_gradient_in_world_units(head):
    result = run("GradientMagnitude", head)
    reference = np.sqrt(sum(g ** 2 for g in np.gradient(head.data.astype(np.float64), 1.5, 3.2, 3.2)))
    assert result.data.dtype == np.float32 and not result.holds_labels
    assert_close(result.data, reference)
    assert result.value_range == pytest.approx((0.0, reference.max()), rel=1e-6)


def test_gaussian_derivatives_equal_scipy(head):
    isotropic = head.with_overrides(spacing=(1.0, 1.0, 1.0))
    result = run("GradientMagnitude", isotropic, method="gaussian", sigma=(2.0, 2.0, 2.0))
    assert_close(result.data, ndimage.gaussian_gradient_magnitude(head.data.astype(np.float64), 2.0))
    # anisotropic: sigma 3.2, 6.4, 3 world units = 1, 2, 2 voxels; each derivative per world unit
    result = run("GradientMagnitude", head, method="gaussian", sigma=(3.2, 6.4, 3.0))
    data, sigma = head.data.astype(np.float64), (2.0, 2.0, 1.0)
    derivatives = [ndimage.gaussian_filter(data, sigma, order=tuple(int(a == axis) for a in range(3))) / s
                   for axis, s in enumerate((1.5, 3.2, 3.2))]
    assert_close(result.data, np.sqrt(sum(d ** 2 for d in derivatives)))


@pytest.mark.parametrize("method", ["central", "gaussian"])
@pytest.mark.parametrize("direction", [None, TILT])
def test_a_linear_ramp_has_its_slope_per_world_unit_everywhere(method, direction):
    volume = Volume(np.zeros((30, 24, 20)), spacing=(2.0, 0.5, 1.5), direction=direction or np.eye(3))
    k, j, i = np.indices(volume.data.shape)
    x, y, z = np.moveaxis(volume.voxel_to_world(np.stack([i, j, k], axis=-1)), -1, 0)
    ramp = volume.with_data(2.0 * x + 3.0 * y - z)
    result = run("GradientMagnitude", ramp, method=method, sigma=(2.0, 1.0, 1.5)).data
    if method == "central":
        assert np.allclose(result, np.sqrt(14.0), rtol=1e-5)
    else:  # away from the mirrored faces; a sampled Gaussian derivative of 1 voxel is 0.1 % short
        assert np.allclose(result[6:-6, 6:-6, 6:-6], np.sqrt(14.0), rtol=2e-3)


def test_bad_gradient_input_is_named(head):
    labels = head.with_data((head.data > 500).astype(np.uint8), holds_labels=True)
    with pytest.raises(PropertyError, match=r"^f\.method: .*holds labels: a gradient of label numbers"):
        run("GradientMagnitude", labels)
    with pytest.raises(PropertyError, match=r"^f\.sigma: each of x, y, z must be above 0"):
        run("GradientMagnitude", head, method="gaussian", sigma=(0.0, 1.0, 1.0))
    with pytest.raises(PropertyError, match=r"^f\.sigma: the kernel reaches 94 voxels along z"):
        run("GradientMagnitude", head, method="gaussian", sigma=(1.0, 1.0, 35.0))


# --- VolumeMath ---------------------------------------------------------------------------------
@pytest.mark.parametrize("operation, reference", [
    ("add", lambda a, b: a + b), ("subtract", lambda a, b: a - b), ("multiply", lambda a, b: a * b),
    ("min", np.minimum), ("max", np.maximum)])
def test_math_equals_numpy_voxel_by_voxel(head, operation, reference):
    other = head.with_data(ndimage.gaussian_filter(head.data.astype(np.float32), 1.0))
    result = run("VolumeMath", first=head, second=other, operation=operation)
    assert_close(result.data, reference(head.data.astype(np.float64), other.data.astype(np.float64)))
    assert result.data.dtype == np.float32 and np.array_equal(result.affine, head.affine)
    # no overflow in small integer types
    small = Volume(np.full((4, 4, 4), 200, dtype=np.uint8))
    assert run("VolumeMath", first=small, second=small, operation="add").data.max() == 400.0


def test_math_mask_keeps_the_first_where_the_second_is_not_zero(head, bone):
    result = run("VolumeMath", first=head, second=bone, operation="mask", outside=-5.0)
    assert result.data.dtype == np.int16 and np.array_equal(result.data, np.where(bone.data != 0, head.data, -5))
    assert result.value_range == head.value_range
    with pytest.raises(PropertyError, match=r"^f\.outside: 2\.5 does not fit the volume's type int16"):
        run("VolumeMath", first=head, second=bone, operation="mask", outside=2.5)


@pytest.mark.parametrize("change, words", [
    ({"origin": (1.0, 0.0, 0.0)}, r"origin 1 x 0 x 0 and 0 x 0 x 0"),
    ({"spacing": (3.2, 3.2, 1.6)}, r"spacing 3\.2 x 3\.2 x 1\.6 and 3\.2 x 3\.2 x 1\.5"),
    ({"direction": TILT}, r"direction \[\[0\.0, -1\.0, 0\.0\], .* and \[\[1\.0, 0\.0, 0\.0\], .*")])
def test_math_on_different_grids_is_a_named_error(head, change, words):
    moved = head.with_overrides(**change)
    with pytest.raises(GridMismatchError, match=rf"^f\.grid: f\.first \(.*quarter.nhdr\) and f\.second .* lie on "
                                                rf"different grids \({words}\): resample one onto the other"):
        run("VolumeMath", first=moved, second=head)
    cropped = head.with_data(head.data[:, :, :40].copy())
    with pytest.raises(GridMismatchError, match=r"dims 64 x 64 x 93 and 40 x 64 x 93"):
        run("VolumeMath", first=head, second=cropped)


@pytest.mark.parametrize("labels", [False, True])
def test_math_resamples_the_second_onto_the_first_grid_in_world_space(head, labels):
    first = head.with_data(head.data, holds_labels=labels)
    # the same voxels stored mirrored along x and turned: the same world positions, another grid
    turned = Volume(first.data[:, :, ::-1].copy(), spacing=head.spacing, holds_labels=labels,
                    origin=tuple(head.voxel_to_world((63, 0, 0))), direction=((-1, 0, 0), (0, 1, 0), (0, 0, 1)))
    result = run("VolumeMath", first=first, second=turned, operation="subtract", grid="resample")
    # nearest exactly; linear at positions a rounding off the voxel centres
    assert np.abs(result.data).max() <= (0 if labels else 1e-6 * 3926)
    # a part of it: equal inside the part's voxel cells, 0 beyond
    part = first.with_data(first.data[20:60, 10:50, 5:45].copy(), origin=tuple(head.voxel_to_world((5, 10, 20))))
    kept = run("VolumeMath", first=first, second=part, operation="max", grid="resample").data
    outside = np.ones(head.data.shape, bool)
    outside[20:60, 10:50, 5:45] = False
    assert np.allclose(kept[~outside], head.data[~outside], rtol=0, atol=1e-6 * 3926)
    assert np.array_equal(kept[outside], np.maximum(head.data[outside], 0))


# --- VolumeMask ---------------------------------------------------------------------------------
def test_mask_keeps_the_voxels_of_the_chosen_labels(head):
    labels = head.with_data(np.digitize(head.data, [500, 1150]).astype(np.uint8), holds_labels=True)
    kept = run("VolumeMask", head, labels=labels, keep="2")
    assert np.array_equal(kept.data, np.where(labels.data == 2, head.data, 0))
    assert kept.value_range == head.value_range and np.array_equal(kept.affine, head.affine)
    both = run("VolumeMask", head, labels=labels, keep="1, 2", outside=-1.0)
    assert np.array_equal(both.data, np.where(labels.data > 0, head.data, -1))
    assert np.array_equal(run("VolumeMask", head, labels=labels).data, both.data.clip(0))  # empty: all but 0


def test_bad_masks_are_named(head, bone):
    with pytest.raises(PropertyError, match=r"""^f\.keep: '1, two' is not a list of whole numbers"""):
        run("VolumeMask", head, labels=bone, keep="1, two")
    with pytest.raises(GridMismatchError, match=r"^f\.labels: f\.volume .* and f\.labels .* lie on different "
                                                r"grids \(origin .*\): resample the labels onto the volume"):
        run("VolumeMask", head, labels=bone.with_overrides(origin=(0.0, 0.0, 5.0)))
    small = Volume(np.ones((4, 4, 4), dtype=np.uint8))
    with pytest.raises(PropertyError, match=r"^f\.outside: 300 does not fit the volume's type uint8 \(whole "
                                            r"numbers 0 \.\. 255\)"):
        run("VolumeMask", small, labels=Volume(np.ones((4, 4, 4), dtype=np.uint8)), outside=300.0)


def test_the_segmentation_processors_are_volume_filters_with_documented_properties():
    for name in ("VolumeMorphology", "ConnectedComponents", "GradientMagnitude", "VolumeMath", "VolumeMask"):
        cls = registry.get(name)
        assert cls.category == "Volume filters" and cls.__doc__
        assert all(p.doc for p in cls.properties.values()), name


def test_the_processors_chain_in_a_network_and_errors_name_the_processor():
    network = Network()
    network.add("FunctionSelector", id="src", function="sphere", resolution=32)
    network.add("VolumeThreshold", id="threshold", lower=0.5)
    network.add("VolumeMorphology", id="open", operation="open", radius=0.1)
    network.add("ConnectedComponents", id="parts")
    network.add("VolumeMask", id="mask", keep="1")
    network.add("GradientMagnitude", id="gradient")
    network.add("VolumeMath", id="math", operation="multiply")
    for a, b in [("src", "threshold"), ("threshold", "open"), ("open", "parts"), ("src", "mask"),
                 ("mask", "gradient"), ("gradient", "math.first")]:
        network.connect(f"{a}.volume", b if "." in b else f"{b}.volume")
    network.connect("parts.volume", "mask.labels")
    network.connect("src.volume", "math.second")
    result = network.evaluate("math.volume")
    assert result.shape == (32, 32, 32) and result.max() > 0
    assert network.output("parts.volume").component_count == 1
    network.add("ImageSource", id="picture")
    with pytest.raises(VGraphError, match=r"Image.*Volume|Volume.*Image"):  # a 2D image into a volume port
        network.connect("picture.image", "math.second")
    network.set("open.radius", 5.0)
    with pytest.raises(ProcessorError, match=r"'open' \(VolumeMorphology\): open\.radius: the ball reaches"):
        network.evaluate("math.volume")


# --- networks/segment_engine.json ---------------------------------------------------------------
def test_segment_engine_renders_its_labelled_parts():
    from helpers.paths import DATA, REPO
    if not (DATA / "ct_engine" / "engine.nii.gz").is_file():
        pytest.skip("shared data set ct_engine not found")
    import vgraph
    from vgraph.labels import palette_color
    network = vgraph.load(REPO / "networks" / "segment_engine.json")
    description = json.loads((REPO / "networks" / "segment_engine.json").read_text())["description"]
    assert "ConnectedComponents" in description
    image = np.asarray(network.evaluate("canvas", size=(160, 160)))[..., :3]
    parts = network.output("components.volume")
    assert parts.component_count >= 4 and parts.voxel_counts.min() * 1.0 >= 100.0  # engine spacing 1 mm
    # each of the largest parts shows, in its palette colour: hidden, the picture loses that colour
    for value in (1, 2, 3):
        network.set("labels.label_table", {"labels": [{"value": 0, "visible": False, "opacity": 0.0},
                                                      {"value": value, "visible": False}]})
        hidden = np.asarray(network.evaluate("canvas", size=(160, 160)))[..., :3]
        changed = np.abs(image - hidden).max(axis=-1) > 0.05
        assert changed.sum() > 40, f"label {value} does not show"
        lost = (image - hidden)[changed].mean(axis=0)
        colors = np.array([palette_color(v) for v in range(1, 6)])
        likeness = colors @ lost / np.linalg.norm(colors, axis=1) / np.linalg.norm(lost)
        assert np.argmax(likeness) == value - 1 and likeness[value - 1] > 0.95, likeness
    # without the labels only the casing is left, in its blue: no yellow or orange anywhere
    network.set("labels.label_table", {"labels": [], "unlisted": "hidden"})
    bare = np.asarray(network.evaluate("canvas", size=(160, 160)))[..., :3]
    warm = lambda picture: (picture[..., 0] > picture[..., 2] + 0.1).sum()  # noqa: E731
    assert warm(bare) == 0 and warm(image) > 500 and bare.max() > 0.2
