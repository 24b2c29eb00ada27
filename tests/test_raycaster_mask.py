"""Masks and cut-aways of the RayCaster (vgraph.masking, vgraph.gl.raycasting.mask) on the shared
label volume (networks/data/engine_labels.nrrd, the engine CT classified by
bench/make_label_volume.py: 0 background, 1 casing, 2 dense parts): the first hit never lies in a
voxel of a hidden label; with nearest sampling a mask equals setting the hidden voxels to the lowest
value, bit for bit (first_hit, mip, dvr); mip and dvr match the
CPU reference with the same mask (kept, hidden, smoothed, on a coarser turned grid) and cut-away;
keeping every label is the unmasked image bit for bit; iso surfaces are cut where the mask hides;
the CurvatureVolumeRaycaster, the MultiVolumeRayCaster and the LabelRayCaster (the last two
against their CPU references) take them too; bad input is refused naming processor and port or property (also from the CLI, in one line);
an image they empty names them; the properties survive a .json round trip."""

import numpy as np
import pytest

from vgraph import VGraphError
from vgraph.camera import Camera
from vgraph.fileformat import load_network, save_network
from vgraph.io import read_volume
from vgraph.network import Network
from vgraph.masking import CutAwayRegion, MaskSelection, MaskWeights, kept_indicator
from vgraph.numerics.reference_raycast import render, volume_box
from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.networks import UNSHADED_RAMP, rendering_network
from helpers.paths import DATA, REPO

SIZE = (48, 36)
# float32 GL against the float64 reference, hard masks (measured <= 1e-5, 2.1e-5 with the box:
# the mask voxel and the side of every sample agree; one that flipped would differ by a sample's
# whole contribution)
REFERENCE_TOLERANCE = 5e-5
# smoothed masks: the R8 indicator filtered by llvmpipe with 8-bit weights (measured <= 7e-3)
SMOOTH_TOLERANCE = 1.5e-2
# any visible value is hit: opacity 1 from normalised 0.3 up (the casing starts near 0.31)
STEP = TransferFunction(points=[(0.0, 1, 1, 1, 0.0), (0.299, 1, 1, 1, 0.0), (0.3, 1, 1, 1, 1.0),
                                (1.0, 1, 1, 1, 1.0)])


@pytest.fixture(scope="module")
def engine():
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    return read_volume(DATA / "ct_engine" / "engine.nii.gz")


@pytest.fixture(scope="module")
def labels():
    return read_volume(REPO / "networks" / "data" / "engine_labels.nrrd")


def camera_of(volume):
    return Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))


def masked_network(volume, mask, **properties):
    network = rendering_network(volume, camera_of(volume), **properties)
    if mask is not None:
        network.add(GivenVolume(id="m", volume=mask))
        network.connect("m.volume", "rc.mask")
    return network


def gl_image(volume, mask, **properties):
    return masked_network(volume, mask, **properties).evaluate("rc.image", size=SIZE)


def reference(volume, mode, weights):
    return render(volume, camera_of(volume), UNSHADED_RAMP["transfer_function"], SIZE, mode=mode,
                  sample_weights=weights)


def hit_voxels(image, dims):
    """The voxels (x, y, z) of first_hit's texture coordinates (rgb) where alpha says there is one."""
    hit = image[..., 3] > 0.5
    return np.minimum(np.floor(image[hit][:, :3] * np.asarray(dims)).astype(int), np.asarray(dims) - 1)


def test_the_mask_has_the_labels_of_the_engine(labels):
    assert set(np.unique(labels.data).tolist()) == {0, 1, 2}


@pytest.mark.parametrize("kept, mode", [((2,), "keep"), ((1,), "hide"), ((1, 2), "keep")])
def test_the_first_hit_lies_in_a_kept_voxel(engine, labels, kept, mode):
    """Nearest sampling, mask on the volume's grid: the voxel of every hit (its texture
    coordinates) holds a kept label and a visible value."""
    image = gl_image(engine, labels, compositing="first_hit", interpolation="nearest", transfer_function=STEP,
                     mask_labels=", ".join(map(str, kept)), mask_mode=mode, background=(0, 0, 0, 0))
    voxels = hit_voxels(image, engine.dims)
    hit_labels = labels.data[voxels[:, 2], voxels[:, 1], voxels[:, 0]]
    assert len(voxels) > 50
    assert (np.isin(hit_labels, kept) if mode == "keep" else ~np.isin(hit_labels, kept)).all()
    assert (engine.normalized(engine.data[voxels[:, 2], voxels[:, 1], voxels[:, 0]]) >= 0.3).all()


@pytest.mark.parametrize("compositing", ["first_hit", "mip", "dvr"])
def test_the_mask_hides_exactly_the_voxels_of_the_unchosen_labels(engine, labels, compositing):
    """Nearest sampling: masking keeps label 2 exactly as setting every other voxel to the volume's
    lowest value (the same value range) does, bit for bit, in the image and the depth output."""
    zeroed = np.where(labels.data == 2, engine.data, engine.data.min())
    hidden = Volume(zeroed, spacing=engine.spacing, origin=engine.origin).with_overrides(
        declared_range=engine.value_range)
    properties = {"compositing": compositing, "interpolation": "nearest", "transfer_function": STEP}
    masked = masked_network(engine, labels, mask_labels="2", **properties)
    expected = masked_network(hidden, None, **properties)
    for output in ("image", "depth"):
        image = masked.evaluate(f"rc.{output}", size=SIZE)
        plain = expected.evaluate(f"rc.{output}", size=SIZE)
        if output == "depth":  # r, g, a (b counts the samples taken, which skipping changes)
            image, plain = image[..., [0, 1, 3]], plain[..., [0, 1, 3]]
        assert np.array_equal(image, plain)
    assert not np.array_equal(masked.evaluate("rc.image", size=SIZE),
                              masked_network(engine, None, **properties).evaluate("rc.image", size=SIZE))


def test_keeping_every_label_is_the_unmasked_image_bit_for_bit(engine, labels):
    for mode in ("dvr", "mip"):
        plain = gl_image(engine, None, compositing=mode)
        assert np.array_equal(gl_image(engine, labels, compositing=mode, mask_labels="0, 1, 2"), plain)
        assert not np.array_equal(gl_image(engine, labels, compositing=mode, mask_labels="2"), plain)


@pytest.mark.parametrize("mode", ["mip", "dvr"])
@pytest.mark.parametrize("case", ["keep dense parts", "hide casing and a sphere", "binary mask and a box"])
def test_mip_and_dvr_match_the_cpu_reference(engine, labels, mode, case):
    if case == "keep dense parts":
        properties, weights = {"mask_labels": "2"}, MaskWeights(labels, MaskSelection((2,)))
    elif case == "hide casing and a sphere":
        properties = {"mask_labels": "1", "mask_mode": "hide", "cutaway": "sphere",
                      "cutaway_center": (10.0, -20.0, 0.0), "cutaway_size": (150.0, 150.0, 150.0)}
        weights = MaskWeights(labels, MaskSelection((1,), "hide"),
                              CutAwayRegion("sphere", (10.0, -20.0, 0.0), (150.0, 150.0, 150.0)))
    else:
        properties = {"cutaway": "box", "cutaway_center": (60.0, -60.0, 20.0), "cutaway_size": (140.0, 130.0, 90.0)}
        weights = MaskWeights(labels, MaskSelection(), CutAwayRegion("box", (60.0, -60.0, 20.0), (140.0, 130.0, 90.0)))
    image = gl_image(engine, labels, compositing=mode, **properties)
    expected = reference(engine, mode, weights)
    assert np.abs(image - expected).max() <= REFERENCE_TOLERANCE
    assert np.abs(image - reference(engine, mode, None)).max() > 0.05  # the mask shows


def test_a_mask_on_its_own_coarser_turned_grid_matches_the_reference(engine):
    """A ball of label 3 on a 3 mm grid turned by 30 degrees about z and shifted: sampled through
    its own affine, not the volume's grid."""
    turn = np.radians(30.0)
    direction = ((np.cos(turn), -np.sin(turn), 0.0), (np.sin(turn), np.cos(turn), 0.0), (0.0, 0.0, 1.0))
    z, y, x = np.mgrid[0:40, 0:50, 0:60]
    ball = ((x - 30) / 25.0) ** 2 + ((y - 25) / 20.0) ** 2 + ((z - 20) / 15.0) ** 2 <= 1.0
    mask = Volume(ball.astype(np.uint8) * 3, spacing=(3.0, 3.0, 3.0), origin=(-60.0, -80.0, -40.0),
                  direction=direction)
    for mode in ("mip", "dvr"):
        image = gl_image(engine, mask, compositing=mode, mask_labels="3")
        assert np.abs(image - reference(engine, mode, MaskWeights(mask, MaskSelection((3,))))).max() \
            <= REFERENCE_TOLERANCE
        assert 0.02 < (image[..., :3] > 0).mean() < 0.5


def test_a_smoothed_mask_matches_the_reference_and_softens_the_edge(engine, labels):
    selection = MaskSelection((2,), "keep", "smooth", 1.0)
    indicator = kept_indicator(labels, selection, "test")
    assert 0 < ((indicator > 0) & (indicator < 255)).sum()  # a soft edge
    for mode in ("mip", "dvr"):
        properties = {"mask_labels": "2", "mask_boundary": "smooth", "mask_smoothing": 1.0}
        image = gl_image(engine, labels, compositing=mode, **properties)
        assert np.abs(image - reference(engine, mode, MaskWeights(labels, selection))).max() <= SMOOTH_TOLERANCE


def test_bad_masks_are_refused_naming_processor_and_port(engine, labels):
    fractional = Volume(labels.data.astype(np.float32) + 0.5, spacing=labels.spacing, origin=labels.origin)
    with pytest.raises(VGraphError, match=r"rc\.mask.*integer labels"):
        masked_network(engine, fractional, mask_labels="1").evaluate("rc.image", size=SIZE)
    far = Volume(labels.data, spacing=labels.spacing, origin=(1000.0, 0.0, 0.0))
    with pytest.raises(VGraphError, match=r"rc\.mask.*does not overlap"):
        masked_network(engine, far).evaluate("rc.image", size=SIZE)
    with pytest.raises(VGraphError, match=r"rc\.mask.*no voxel of label 7 \(it holds 0, 1, 2\)"):
        masked_network(engine, labels, mask_labels="2, 7").evaluate("rc.image", size=SIZE)
    with pytest.raises(VGraphError, match=r"rc\.mask_labels.*'dense' is not a list of integer labels"):
        masked_network(engine, labels, mask_labels="dense")
    with pytest.raises(VGraphError, match=r"rc\.cutaway_size.*sizes > 0"):
        masked_network(engine, None, cutaway="box", cutaway_size=(1.0, 0.0, 1.0)).evaluate("rc.image", size=SIZE)


def test_a_binary_float_mask_needs_no_integer_labels(engine, labels):
    """No labels listed: every nonzero voxel is in, whatever the type."""
    binary = Volume((labels.data == 2).astype(np.float32) * 0.7, spacing=labels.spacing, origin=labels.origin)
    assert np.array_equal(gl_image(engine, binary, compositing="mip"),
                          gl_image(engine, labels, compositing="mip", mask_labels="2"))


def test_mask_and_cutaway_properties_survive_a_json_round_trip(tmp_path):
    network = Network()
    network.add("RayCaster", id="rc", mask_labels="1, 2", mask_mode="hide", mask_boundary="smooth",
                mask_smoothing=2.0, cutaway="sphere", cutaway_center=(1.0, 2.0, 3.0), cutaway_size=(4.0, 5.0, 6.0))
    save_network(network, tmp_path / "masked.json")
    loaded = load_network(tmp_path / "masked.json")
    for name, value in (("mask_labels", "1, 2"), ("mask_mode", "hide"), ("mask_boundary", "smooth"),
                        ("mask_smoothing", 2.0), ("cutaway", "sphere"), ("cutaway_center", (1.0, 2.0, 3.0)),
                        ("cutaway_size", (4.0, 5.0, 6.0))):
        assert loaded.get(f"rc.{name}") == value


def test_the_curvature_volume_raycaster_takes_the_mask_and_the_cutaway():
    """Its opacity is weighed as the RayCaster's dvr: a mask keeping everything is the unmasked
    image bit for bit; one keeping the half x < centre leaves fewer pixels with a visible sample
    (depth output); a cut-away box around the whole volume leaves the background."""
    from helpers.curvature import TORUS_CAMERA, curvature_network
    from vgraph.implicit import sample
    torus = sample("torus", 48, "float32")
    half = np.zeros(torus.data.shape, dtype=np.uint8)
    half[:, :, :24] = 1

    def network(mask, **properties):
        built = curvature_network(torus, TORUS_CAMERA, processor="CurvatureVolumeRaycaster",
                                  normalization="linear", derivatives="central", **properties)
        if mask is not None:
            built.add(GivenVolume(id="m", volume=Volume(mask, spacing=torus.spacing, origin=torus.origin)))
            built.connect("m.volume", "cr.mask")
        return built

    plain = network(None).evaluate("cr.image", size=SIZE)
    assert np.array_equal(network(np.ones_like(half)).evaluate("cr.image", size=SIZE), plain)
    coverage = network(None).evaluate("cr.depth", size=SIZE)[..., 3]  # 1 where a sample has opacity
    masked = network(half).evaluate("cr.depth", size=SIZE)[..., 3]
    assert 0.2 * coverage.mean() < masked.mean() < 0.8 * coverage.mean() and (masked <= coverage).all()
    from vgraph.scheduler import BlankImageWarning
    with pytest.warns(BlankImageWarning, match=r"cr\.cutaway \(box"):
        background = network(None, cutaway="box", cutaway_size=(10.0, 10.0, 10.0)).evaluate("cr.image", size=SIZE)
    assert np.array_equal(background, np.broadcast_to(background[0, 0], background.shape))


@pytest.mark.parametrize("case", ["lps", "turned", "tiny box"])
def test_masks_and_cutaways_follow_oriented_and_extreme_volumes(engine, labels, case):
    """Volume and mask share a grid that is mirrored (LPS), turned by 20 degrees, or 1e-9 mm
    small (drawn in its normalised frame): the ray positions go through the frame and the
    volume's direction to the world, then into the mask's and the region's coordinates."""
    turn = np.radians(20.0)
    direction = {"lps": ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
                 "turned": ((np.cos(turn), 0.0, np.sin(turn)), (0.0, 1.0, 0.0), (-np.sin(turn), 0.0, np.cos(turn))),
                 "tiny box": ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0))}[case]
    scale = 1e-9 if case == "tiny box" else 1.0
    grid = {"spacing": tuple(np.asarray(engine.spacing) * scale), "origin": (10.0 * scale, 20.0 * scale, 5.0 * scale),
            "direction": direction}
    volume, mask = Volume(engine.data, **grid), Volume(labels.data, **grid)
    region = CutAwayRegion("sphere", grid["origin"], (120.0 * scale,) * 3)
    image = gl_image(volume, mask, compositing="dvr", mask_labels="2", cutaway="sphere",
                     cutaway_center=region.center, cutaway_size=region.size)
    expected = reference(volume, "dvr", MaskWeights(mask, MaskSelection((2,)), region))
    assert np.abs(image - expected).max() <= REFERENCE_TOLERANCE
    assert np.abs(image - reference(volume, "dvr", None)).max() > 0.05


def test_an_image_emptied_by_the_cutaway_or_the_mask_names_them(engine, labels):
    from vgraph.scheduler import BlankImageWarning
    with pytest.warns(BlankImageWarning, match=r"rc\.cutaway \(box at \[0\.0, 0\.0, 0\.0\], size \[1000\.0, "
                                               r"1000\.0, 1000\.0\]\) removed every visible sample"):
        masked_network(engine, None, cutaway="box", cutaway_size=(1000.0, 1000.0, 1000.0)).evaluate(
            "rc.image", size=SIZE)
    with pytest.warns(BlankImageWarning, match=r"rc\.mask \(hide 0, 1, 2\) removed every visible sample"):
        masked_network(engine, labels, mask_labels="0, 1, 2", mask_mode="hide").evaluate("rc.image", size=SIZE)


def test_the_iso_surface_is_cut_where_the_mask_hides(engine, labels):
    """iso, mask keeping label 2: every hit lies in or next to (one voxel) a label-2 voxel, no hit
    is nearer than the unmasked one, some are farther (the surfaces of the casing are gone), and
    keeping every label is the unmasked image bit for bit."""
    properties = {"compositing": "iso", "iso_level": 0.5}
    plain = masked_network(engine, None, **properties)
    assert np.array_equal(masked_network(engine, labels, mask_labels="0, 1, 2", **properties)
                          .evaluate("rc.image", size=SIZE), plain.evaluate("rc.image", size=SIZE))
    masked = masked_network(engine, labels, mask_labels="2", **properties)
    depth, unmasked = masked.evaluate("rc.depth", size=SIZE), plain.evaluate("rc.depth", size=SIZE)
    hit = depth[..., 3] > 0.5
    assert 50 < hit.sum() < (unmasked[..., 3] > 0.5).sum() and (unmasked[..., 3][hit] > 0.5).all()
    assert (depth[..., 1][hit] >= unmasked[..., 1][hit] - 1e-3).all()
    assert (depth[..., 1][hit] > unmasked[..., 1][hit] + 1.0).any()
    camera = masked["rc"].view_camera
    origins, directions = camera.rays(*SIZE)
    points = origins[hit] + depth[..., 1][hit][:, None] * directions[hit]
    voxels = np.rint(labels.world_to_voxel(points)).astype(int)
    near_dense = [(labels.data[max(z - 1, 0):z + 2, max(y - 1, 0):y + 2, max(x - 1, 0):x + 2] == 2).any()
                  for x, y, z in voxels]
    assert all(near_dense)
    assert (labels.data[voxels[:, 2], voxels[:, 1], voxels[:, 0]] == 2).mean() > 0.9


def test_the_cli_renders_the_shipped_network_and_refuses_a_missing_label_in_one_line(tmp_path, capsys, engine):
    from vgraph.cli import main
    network = str(REPO / "networks" / "mask_engine.json")
    assert main(["run", network, "-o", str(tmp_path / "dense.png"), "--size", "64x48"]) == 0
    assert (tmp_path / "dense.png").stat().st_size > 0
    capsys.readouterr()
    assert main(["run", network, "-o", str(tmp_path / "none.png"), "--set", "rc.mask_labels=7"]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "rc.mask" in error and "no voxel of label 7 (it holds 0, 1, 2)" in error


def test_mask_labels_take_a_number_or_a_list_as_text():
    network = Network()
    network.add("RayCaster", id="rc")
    for value, text in ((2, "2"), ([1, 3], "1, 3"), ("1 3", "1 3"), ("", "")):
        network.set("rc.mask_labels", value)
        assert network.get("rc.mask_labels") == text
    with pytest.raises(VGraphError, match=r"rc\.mask_labels.*'1\.5' is not a list of integer labels"):
        network.set("rc.mask_labels", "1.5")


@pytest.mark.parametrize("blend", ["accumulate", "nearest_opaque", "maximum"])
def test_the_multi_volume_raycaster_weighs_every_channel_as_the_cpu_reference(blend):
    """Two channels (torus, shifted copy); a mask of label 1 on its own 0.25-unit grid turned by
    30 degrees, and a sphere cut away: GL and the multivolume CPU reference with the same weights."""
    from helpers.multivolume import BLUE, ORANGE, REFERENCE_TOLERANCE, multivolume_network, oblique_camera, shifted
    from vgraph.implicit import sample
    from vgraph.numerics.multivolume_reference import render_channels
    torus = sample("torus", 28, "float32")
    channels = [torus, shifted(torus, (4, -3, 2))]
    turn = np.radians(30.0)
    direction = ((np.cos(turn), -np.sin(turn), 0.0), (np.sin(turn), np.cos(turn), 0.0), (0.0, 0.0, 1.0))
    half = np.zeros((10, 10, 10), dtype=np.uint8)
    half[:, :, :5] = 1
    mask = Volume(half, spacing=(0.25, 0.25, 0.25), origin=(-1.0, -1.4, -1.2), direction=direction)
    region = CutAwayRegion("sphere", (0.4, 0.5, 0.0), (0.8, 0.8, 0.8))
    camera = oblique_camera(torus)
    network = multivolume_network(channels, camera, blend=blend, transfer_function1=ORANGE, transfer_function2=BLUE,
                                  opacity_threshold=0.3, mask_labels="1", cutaway="sphere",
                                  cutaway_center=region.center, cutaway_size=region.size)
    network.add(GivenVolume(id="m", volume=mask))
    network.connect("m.volume", "mv.mask")
    image = network.evaluate("mv.image", size=SIZE)
    pairs = [(channels[0], ORANGE), (channels[1], BLUE)]
    expected = render_channels(pairs, camera, SIZE, blend=blend, opacity_threshold=0.3,
                               sample_weights=MaskWeights(mask, MaskSelection((1,)), region))
    np.testing.assert_allclose(image, expected, atol=REFERENCE_TOLERANCE)
    assert np.abs(expected - render_channels(pairs, camera, SIZE, blend=blend, opacity_threshold=0.3)).max() > 0.1


@pytest.mark.parametrize("compositing", ["composite", "first_hit"])
def test_the_label_raycaster_takes_the_mask_and_the_cutaway_as_its_cpu_reference(labels, compositing):
    """The engine's labels cut by a sphere and masked by a coarse turned box of label 1 on its own
    grid (the LabelRayCaster's reference works in texture coordinates: the weights are asked at
    their world points); keeping every label without a region is the unmasked picture bit for bit."""
    from vgraph.numerics.reference_labels import render_labels
    turn = np.radians(25.0)
    direction = ((np.cos(turn), -np.sin(turn), 0.0), (np.sin(turn), np.cos(turn), 0.0), (0.0, 0.0, 1.0))
    box = np.zeros((20, 30, 30), dtype=np.uint8)
    box[2:18, 4:26, 3:20] = 1
    mask = Volume(box, spacing=(8.0, 8.0, 6.0), origin=(-110.0, -130.0, -60.0), direction=direction)
    region = CutAwayRegion("sphere", (40.0, -40.0, 30.0), (120.0, 120.0, 120.0))
    table = load_network(REPO / "networks" / "labels_engine.json").get("labels.label_table")
    camera = camera_of(labels)

    def network(mask_volume, **properties):
        built = ray_caster_network(labels, camera, "LabelRayCaster", "lrc", inport="labels", label_table=table,
                                   compositing=compositing, **properties)
        if mask_volume is not None:
            built.add(GivenVolume(id="m", volume=mask_volume))
            built.connect("m.volume", "lrc.mask")
        return built

    plain = network(None).evaluate("lrc.image", size=SIZE)
    assert np.array_equal(network(labels, mask_labels="0, 1, 2").evaluate("lrc.image", size=SIZE), plain)
    masked = network(mask, mask_labels="1", cutaway="sphere", cutaway_center=region.center, cutaway_size=region.size)
    image = masked.evaluate("lrc.image", size=SIZE)
    entry, exit_ = masked.evaluate("eep.entry", size=SIZE), masked.evaluate("eep.exit", size=SIZE)
    weights = MaskWeights(mask, MaskSelection((1,)), region)
    dims = np.asarray(labels.dims, dtype=np.float64)
    expected = render_labels(labels, table, entry, exit_, mode=compositing,
                             sample_weights=lambda t: weights(labels.voxel_to_world(t * dims - 0.5)))
    assert np.abs(image - expected).max() <= REFERENCE_TOLERANCE
    assert np.abs(image - plain).max() > 0.3
