"""LabelRayCaster and label tables: pictures against the numpy reference (same majority rule at the
same samples, same compositing), no colour between two touching labels and the boundary half-way
between voxel centres, the majority rule's rounded corners, hidden and unlisted labels, labels
beyond 16 bits, refused volumes, and the table's validation and .json round trip."""

import json

import numpy as np
import pytest
from scipy import ndimage

from vgraph import ProcessorError, derived
from vgraph.camera import Camera
from vgraph.errors import NetworkFileError, PropertyError, VGraphError
from vgraph.fileformat import load_network, save_network
from vgraph.gl_context import get_context
from vgraph.gl.raycasting.components import EmptySpace
from vgraph.labels import BACKGROUND, LabelEntry, LabelTable, label_codes, majority, palette_color
from vgraph.network import Network
from vgraph.scheduler import BlankImageWarning
from vgraph.numerics.reference_labels import render_labels
from vgraph.numerics.reference_raycast import volume_box
from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.volume import Volume

from helpers.paths import REPO

SIZE = (56, 44)
# Max |GL - reference| per channel; measured on llvmpipe: <= 1.7e-6 (float32 weights and pow).
TOLERANCE = 2e-5
RED, GREEN, BLUE = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
HEADLIGHT = {"ambient": 0.3, "diffuse": 0.7, "specular": 0.2, "shininess": 32.0}


def table(*entries, **rules) -> LabelTable:
    rows = [LabelEntry(value=0, opacity=0.0, visible=False)]
    rows += [LabelEntry(value=value, color=color, opacity=opacity) for value, color, opacity in entries]
    return LabelTable(labels=rows, **rules)


def label_network(volume: Volume, camera: Camera, **properties) -> Network:
    """GivenVolume 'src' -> EntryExitPoints 'eep' -> LabelRayCaster 'lrc' (its inport is 'labels')."""
    return ray_caster_network(volume, camera, "LabelRayCaster", "lrc", inport="labels", **properties)


def render_both(volume, camera, size=SIZE, shading=None, **properties):
    """(GL picture, reference picture) of the same network's entry and exit points."""
    network = label_network(volume, camera, shading="blinn_phong" if shading else "none", **properties)
    gl = network.evaluate("lrc.image", size=size)
    entry, exit_ = network.evaluate("eep.entry", size=size), network.evaluate("eep.exit", size=size)
    reference = render_labels(volume, network.get("lrc.label_table"), entry, exit_,
                              mode=network.get("lrc.compositing"), sampling_rate=network.get("lrc.sampling_rate"),
                              background=network.get("lrc.background"), shading=shading)
    return gl, reference


def colours(image, decimals=5) -> set:
    return {tuple(float(v) for v in c) for c in image[..., :3].reshape(-1, 3).astype(np.float64).round(decimals)}


def oblique_camera(volume):
    return Camera.looking_at_box(*volume_box(volume), direction=(-0.5, -0.3, -1.0))


def top_camera(volume):
    """Orthographic, looking down -z; the view spans voxel edges -0.5 .. n - 0.5 in x and y."""
    lo, hi = volume_box(volume)
    centre = (lo + hi) / 2
    return Camera(projection="orthographic", position=(centre[0], centre[1], hi[2] + 5.0), focus=tuple(centre),
                  near=1.0, far=50.0, parallel_scale=volume.dims[1] * volume.spacing[1] / 2)


@pytest.fixture(scope="module")
def blobs():
    """Four labels (0, 1, 2, 5) from smoothed noise: curved boundaries, junctions of three labels."""
    noise = ndimage.gaussian_filter(np.random.default_rng(3).random((14, 12, 16)), 2.0)
    classes = np.digitize(noise, np.quantile(noise, [0.4, 0.6, 0.8]))
    return Volume(np.array([0, 1, 2, 5], dtype=np.uint8)[classes], spacing=(0.8, 1.0, 0.5),
                  origin=(1.0, -2.0, 3.0))


def touching_boxes(dtype=np.uint8, low=1, high=3) -> Volume:
    """Label ``low`` at x in [2, 8), label ``high`` at x in [8, 14), y in [2, 8), z in [2, 6)."""
    data = np.zeros((8, 10, 16), dtype=dtype)
    data[2:6, 2:8, 2:8] = low
    data[2:6, 2:8, 8:14] = high
    return Volume(data)


BOX_TABLE = table((1, RED, 1.0), (2, GREEN, 1.0), (3, BLUE, 1.0))


# --- against the numpy reference ----------------------------------------------------------------
@pytest.mark.parametrize("mode, rate, shaded, rules", [
    ("composite", 1.0, False, {}), ("composite", 2.5, False, {}), ("composite", 1.0, True, {}),
    ("first_hit", 1.0, False, {}), ("first_hit", 0.7, True, {}),
    ("composite", 1.0, False, {"unlisted": "hidden"})])
def test_matches_the_numpy_reference(blobs, mode, rate, shaded, rules):
    labels = table((1, (0.9, 0.6, 0.2), 0.3), (2, (0.2, 0.5, 0.9), 0.15), **rules)  # 5: unlisted
    gl, reference = render_both(blobs, oblique_camera(blobs), shading=HEADLIGHT if shaded else None,
                                label_table=labels, compositing=mode, sampling_rate=rate,
                                background=(0.1, 0.2, 0.3, 1.0))
    assert np.abs(reference - reference[0, 0]).max() > 0.3      # the labels are in the picture
    np.testing.assert_allclose(gl, reference, atol=TOLERANCE)


def test_a_hidden_label_counts_as_background(blobs):
    shown = table((1, RED, 1.0), (2, GREEN, 1.0), (5, BLUE, 1.0))
    hidden = shown.with_entry(LabelEntry(value=2, color=GREEN, visible=False))
    camera = oblique_camera(blobs)
    gl, reference = render_both(blobs, camera, label_table=hidden, compositing="first_hit")
    np.testing.assert_allclose(gl, reference, atol=TOLERANCE)
    seen = colours(gl, 6)
    assert GREEN not in seen and RED in seen and BLUE in seen
    everything, _ = render_both(blobs, camera, label_table=shown, compositing="first_hit")
    assert GREEN in colours(everything, 6)


@pytest.mark.parametrize("mode", ["composite", "first_hit"])
def test_skipping_blocks_without_shown_labels_changes_no_pixel(mode):
    """Three small boxes in a 40^3 volume (most blocks empty, so skipping is on; ray bounds asked
    for), one of them hidden: the same picture with and without skipping, and the reference's."""
    data = np.zeros((40, 40, 40), dtype=np.uint16)
    data[4:12, 5:15, 6:20], data[20:30, 22:36, 10:18], data[30:37, 3:12, 25:38] = 1, 7, 300
    volume = Volume(data, spacing=(1.0, 0.9, 1.2))
    labels = table((1, RED, 0.4), (7, GREEN, 0.7), (300, BLUE, 1.0)).with_entry(LabelEntry(value=7, visible=False))
    camera = oblique_camera(volume)
    skipped, reference = render_both(volume, camera, shading=HEADLIGHT, label_table=labels, compositing=mode)
    network = label_network(volume, camera, shading="blinn_phong", label_table=labels, compositing=mode,
                            ray_bounds=True)
    processor = network.processors["lrc"]
    network.evaluate("lrc.image", size=SIZE)
    assert dict(processor.passes[-1][1])["SKIP_EMPTY_SPACE"] and dict(processor.passes[-1][1])["RAY_BOUNDS"]
    network.set("lrc.empty_space_skipping", False)
    np.testing.assert_array_equal(network.evaluate("lrc.image", size=SIZE), skipped)
    np.testing.assert_allclose(skipped, reference, atol=TOLERANCE)
    assert np.abs(reference - reference[0, 0]).max() > 0.3


# --- touching labels ----------------------------------------------------------------------------
@pytest.mark.parametrize("mode", ["first_hit", "composite"])
def test_touching_labels_show_only_their_own_colours(mode):
    """Labels 1 and 3 side by side: no purple average and no label 2 (green) anywhere, from an
    oblique view whose rays cross the boundary between the voxel centres."""
    boxes = touching_boxes()
    gl, reference = render_both(boxes, oblique_camera(boxes), size=(96, 80), label_table=BOX_TABLE,
                                compositing=mode)
    np.testing.assert_allclose(gl, reference, atol=TOLERANCE)
    seen = colours(gl)
    assert seen == {RED, BLUE, (0.0, 0.0, 0.0)}


def test_a_clip_plane_in_the_entry_exit_points_cuts_the_labels():
    """A plane keeping x >= 9.2 voxels removes label 1 (x < 8) and shows label 3's inside from the
    cut: GL equals the reference on the clipped entry and exit points."""
    boxes = touching_boxes()
    network = label_network(boxes, oblique_camera(boxes), label_table=BOX_TABLE, compositing="first_hit")
    network.set("eep.clip_planes", [{"normal": (1.0, 0.0, 0.0), "point": (9.2, 0.0, 0.0)}])
    gl = network.evaluate("lrc.image", size=SIZE)
    entry, exit_ = network.evaluate("eep.entry", size=SIZE), network.evaluate("eep.exit", size=SIZE)
    np.testing.assert_allclose(gl, render_labels(boxes, BOX_TABLE, entry, exit_, mode="first_hit"), atol=TOLERANCE)
    assert colours(gl) == {BLUE, (0.0, 0.0, 0.0)}


def test_rays_stop_at_opaque_geometry_through_geometry_entry_exit():
    """A wall (the iso-surface x = 10.5 of a ramp) cuts the rays through GeometryEntryExit: labels
    behind it vanish (transparent, to be composited over the wall's image), the rest as the
    reference draws it on the cut entry and exit points."""
    boxes = touching_boxes()
    ramp = Volume(np.broadcast_to(np.arange(16, dtype=np.float32), boxes.data.shape).copy())
    network = label_network(boxes, oblique_camera(boxes), label_table=BOX_TABLE, compositing="first_hit",
                            background=(0.0, 0.0, 0.0, 0.0))
    uncut = network.evaluate("lrc.image", size=SIZE)
    network.add(GivenVolume(id="ramp", volume=ramp))
    network.add("IsoSurfaceExtractor", id="wall", iso_level=10.5 / 15)
    network.add("GeometryRenderer", id="wall_renderer")
    network.add("GeometryEntryExit", id="cut")
    network.link("eep.camera", "wall_renderer.camera")
    network.link("eep.camera", "cut.camera")
    for connection in network.inputs_of("lrc", "entry") + network.inputs_of("lrc", "exit"):
        network.disconnect(connection)
    for source, target in (("ramp.volume", "wall.volume"), ("wall.geometry", "wall_renderer.geometry"),
                           ("src.volume", "wall_renderer.volume"), ("src.volume", "cut.volume"),
                           ("eep.entry", "cut.entry"), ("eep.exit", "cut.exit"),
                           ("wall_renderer.depth", "cut.depth"), ("cut.entry", "lrc.entry"),
                           ("cut.exit", "lrc.exit")):
        network.connect(source, target)
    cut = network.evaluate("lrc.image", size=SIZE)
    entry, exit_ = network.evaluate("cut.entry", size=SIZE), network.evaluate("cut.exit", size=SIZE)
    reference = render_labels(boxes, BOX_TABLE, entry, exit_, mode="first_hit", background=(0.0, 0.0, 0.0, 0.0))
    np.testing.assert_allclose(cut, reference, atol=TOLERANCE)
    hidden = np.abs(cut - uncut).max(axis=-1) > 0.5
    assert hidden.sum() > 10 and (cut[hidden] == 0.0).all()


def test_the_boundary_between_two_labels_is_half_way_between_voxel_centres():
    """Seen from above at 4 pixels a voxel, the columns left of x = 7.5 voxels are label 1 and
    those right of it label 3 (the weights tie at 7.5, half-way between the centres of voxels 7
    and 8); the outer edges of the boxes are half-way too (x = 1.5 and 13.5)."""
    boxes = touching_boxes()
    k = 4
    size = (boxes.dims[0] * k, boxes.dims[1] * k)
    network = label_network(boxes, top_camera(boxes), label_table=BOX_TABLE, compositing="first_hit")
    row = network.evaluate("lrc.image", size=size)[size[1] // 2, :, :3]
    x = -0.5 + (np.arange(size[0]) + 0.5) / k                  # pixel centres in voxel units
    expected = np.where((x > 1.5) & (x < 7.5), 1, np.where((x > 7.5) & (x < 13.5), 3, 0))
    colour = {0: (0.0, 0.0, 0.0), 1: RED, 3: BLUE}
    np.testing.assert_allclose(row, [colour[label] for label in expected], atol=1e-6)


def test_majority_rule_never_makes_intermediate_labels_and_ties_half_way():
    data = np.array([[[1, 3]]])                                 # two voxels along x
    x = np.linspace(0.25, 0.75, 101)                           # centre of voxel 0 to centre of voxel 1
    winner, weight, _ = majority(data, np.stack([x, np.full_like(x, 0.5), np.full_like(x, 0.5)], axis=1))
    assert set(winner) == {1, 3}
    np.testing.assert_array_equal(winner, np.where(x <= 0.5, 1, 3))   # the tie at 0.5: the smaller label
    assert weight.min() == pytest.approx(0.5)


def test_majority_rule_rounds_corners_where_nearest_voxels_would_not():
    """The corner voxel of a label block against background: the label holds where its weight sum
    exceeds one half, (0.5 + d)^2 > 0.5 on the diagonal, so d > 0.207 voxels past the half-way
    point, where nearest-voxel labels would switch at d = 0."""
    classes = np.full((4, 4, 4), BACKGROUND, dtype=np.int64)
    classes[:, 2:, 2:] = 1                                      # x, y >= 2: the corner at (1.5, 1.5)
    for d, inside in ((0.15, False), (0.25, True)):
        point = (np.array([[1.5 + d, 1.5 + d, 1.5]]) + 0.5) / 4.0
        assert (majority(classes, point)[0][0] == 1) == inside


# --- label values and volumes ----------------------------------------------------------------------
def test_labels_beyond_16_bits_and_negative_labels_are_renumbered_and_keep_their_colours():
    boxes = touching_boxes(np.int32, low=-7, high=70000)
    codes = label_codes(boxes.data, "test")
    assert codes.values.tolist() == [-7, 0, 70000]
    labels = LabelTable(labels=[LabelEntry(value=0, visible=False), LabelEntry(value=-7, color=RED)])
    gl, reference = render_both(boxes, oblique_camera(boxes), label_table=labels, compositing="first_hit")
    np.testing.assert_allclose(gl, reference, atol=TOLERANCE)
    seen = colours(gl)
    assert seen == {RED, tuple(round(c, 5) for c in palette_color(70000)), (0.0, 0.0, 0.0)}


def test_whole_floats_render_as_integers_and_fractional_floats_are_refused():
    boxes = touching_boxes()
    as_float = Volume(boxes.data.astype(np.float32))
    camera = oblique_camera(boxes)
    picture = lambda volume: label_network(volume, camera, label_table=BOX_TABLE).evaluate(  # noqa: E731
        "lrc.image", size=SIZE)
    np.testing.assert_array_equal(picture(as_float), picture(boxes))
    data = as_float.data.copy()
    data[3, 4, 5] = 2.5
    with pytest.raises(ProcessorError, match=r"'lrc' \(LabelRayCaster\): lrc.labels \(seg.nrrd\): .*"
                                             r"fractional values, e.g. 2.5 at voxel "
                                             r"\(x=5, y=4, z=3\)"):
        label_network(Volume(data, source="seg.nrrd"), camera).evaluate("lrc.image", size=SIZE)


def test_label_values_beyond_64_bit_signed_integers_are_refused():
    data = np.zeros((2, 2, 2), dtype=np.uint64)
    data[0, 0, 0] = 2**63
    with pytest.raises(VGraphError, match="vol: label values must fit a 64-bit signed integer, "
                                          "got 9223372036854775808"):
        label_codes(data, "vol")


def test_the_codes_texture_and_skip_blocks_are_kept_when_only_colours_change():
    boxes = touching_boxes()
    network = label_network(boxes, oblique_camera(boxes), label_table=BOX_TABLE)
    first = network.evaluate("lrc.image", size=SIZE)
    cached = derived.peek(boxes, "label codes")
    texture = derived.peek(boxes, "label codes texture", ctx=get_context())
    blocks = network.processors["lrc"].parts[EmptySpace].blocks
    skip_key = blocks.key
    network.set("lrc.label_table", BOX_TABLE.with_entry(LabelEntry(value=1, color=GREEN)))
    second = network.evaluate("lrc.image", size=SIZE)
    assert derived.peek(boxes, "label codes") is cached and cached is not None
    assert derived.peek(boxes, "label codes texture", ctx=get_context()) is texture and texture is not None
    assert blocks.key is skip_key                                 # a new colour: the same empty blocks
    assert (np.abs(second - first).max(axis=-1) > 0.5).any()     # label 1 turned from red to green


def test_an_empty_picture_of_shown_labels_blames_the_camera_and_one_of_hidden_labels_the_table():
    boxes = touching_boxes()
    away = Camera(position=(7.5, 4.5, 60.0), focus=(7.5, 4.5, 100.0))
    with pytest.warns(BlankImageWarning, match=r"lrc \(LabelRayCaster\) rendered an empty image although "
                                               r"\d+% of the voxels hold shown labels: seen from eep\.camera"):
        label_network(boxes, away).evaluate("lrc.image", size=SIZE)
    with pytest.warns(BlankImageWarning, match=r"lrc \(LabelRayCaster\) rendered an empty image: "
                                               r"lrc\.label_table hides every label its labels") as caught:
        label_network(boxes, away, label_table={"labels": [], "unlisted": "hidden"}).evaluate("lrc.image", size=SIZE)
    assert "camera" not in str(caught[0].message)  # nothing shows, wherever the camera looks


# --- the label table ----------------------------------------------------------------------------
def test_default_table_hides_label_0_and_draws_other_labels_from_the_palette():
    default = LabelTable.default()
    rgba = default.colors(np.array([0, 1, 2, 21]))
    np.testing.assert_array_equal(rgba[:, 3], [0.0, 1.0, 1.0, 1.0])
    np.testing.assert_allclose(rgba[1:, :3], [palette_color(1), palette_color(2), palette_color(21)])
    assert palette_color(1) != palette_color(2) and palette_color(21) == palette_color(1)  # repeats after 20


def test_label_table_round_trips_through_a_network_file(tmp_path):
    labels = LabelTable(labels=[LabelEntry(value=0, visible=False),
                                LabelEntry(value=4, name="bone", color=(0.9, 0.85, 0.7), opacity=0.25)],
                        unlisted="hidden", unlisted_opacity=0.5)
    network = Network()
    network.add("LabelRayCaster", id="lrc", label_table=labels)
    save_network(network, tmp_path / "labels.json")
    stored = json.loads((tmp_path / "labels.json").read_text())["processors"][0]["properties"]["label_table"]
    assert stored["labels"][1] == {"value": 4, "name": "bone", "color": [0.9, 0.85, 0.7], "opacity": 0.25,
                                   "visible": True}
    assert load_network(tmp_path / "labels.json").get("lrc.label_table") == labels


@pytest.mark.parametrize("bad, reason", [
    ({"labels": [{"value": 1}, {"value": 1}]}, "label 1 is listed twice"),
    ({"labels": [{"value": 1, "opacity": 1.5}]}, "labels.0.opacity: Input should be less than or equal to 1"),
    ({"labels": [{"value": 1, "color": [1, 0]}]}, "labels.0.color"),
    ({"labels": [{"value": 1, "colour": [1, 0, 0]}]}, "labels.0.colour: Extra inputs are not permitted"),
    ({"labels": [{"value": 1.5}]}, "labels.0.value"),
    ({"unlisted": "grey"}, "unlisted: Input should be 'palette' or 'hidden'")])
def test_bad_tables_are_refused_naming_processor_and_field(bad, reason):
    network = Network()
    network.add("LabelRayCaster", id="lrc")
    with pytest.raises(PropertyError, match="^lrc.label_table: ") as error:
        network.set("lrc.label_table", bad)
    assert reason in str(error.value)
    assert network.get("lrc.label_table") == LabelTable.default()    # nothing changed


def test_a_bad_table_in_a_network_file_names_the_file_and_processor(tmp_path):
    network = Network()
    network.add("LabelRayCaster", id="lrc")
    save_network(network, tmp_path / "labels.json")
    document = json.loads((tmp_path / "labels.json").read_text())
    document["processors"][0]["properties"]["label_table"]["labels"][0]["opacity"] = -1
    (tmp_path / "labels.json").write_text(json.dumps(document))
    with pytest.raises(NetworkFileError, match=r"labels.json: processors\[0\].properties.label_table: .*"
                                              r"labels.0.opacity: Input should be greater than or equal to 0"):
        load_network(tmp_path / "labels.json")


def test_the_engine_labels_network_shows_both_materials(data_dir):
    """networks/labels_engine.json: the label volume made by bench/make_label_volume.py; the
    translucent casing (bluish) and the opaque dense parts (orange) are both in the picture."""
    network = load_network(REPO / "networks" / "labels_engine.json")
    image = network.evaluate("labels.image", size=(96, 96))[..., :3]
    orange = (image[..., 0] > image[..., 2] + 0.3).mean()
    blue = (image[..., 2] > image[..., 0] + 0.1).mean()
    assert orange > 0.005 and blue > 0.05
