"""Volumes held to the geometry promises meshes keep (issue 27): a box of voxel centres beyond
+-1e15 is refused naming the file and field, exit 2 (before, `vgraph run ball.npy --set
'source.spacing=[1e14,1e14,1e14]'` raised pydantic's ValidationError for Camera, exit 1), and
extreme but valid boxes (1e-14 .. 1e15 across, or far from the origin) render the picture the
ordinary volume does, drawn in their box's normalised frame (before, a box 1e-11 across was framed
as a speck: a blank image whose warning blamed the camera). Ordinary boxes are drawn in world
units as they were (tests/test_raycaster_fingerprints.py holds their pixels to the bit)."""

import warnings

import numpy as np
import pytest
from PIL import Image as PILImage

import vgraph
from vgraph.bricks.pyramid import ArrayPyramid
from vgraph.bricks.volume import BrickedVolume
from vgraph.camera import Camera
from vgraph.cli import main
from vgraph.clipping import ClipPlane
from vgraph.errors import VolumeFileError
from vgraph.gl.raycasting.framed_view import framed_view
from vgraph.gl.raycasting.geometry import DEFAULT_CAMERA, view_camera
from vgraph.io import read_volume
from vgraph.scheduler import BlankImageWarning
from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.volume import Volume, VolumeGeometryError

N = 24
SIZE = (40, 40)
# Max |difference| of an extreme volume's image from the ordinary one's (RGBA in [0, 1]); measured
# on llvmpipe up to 2.7e-6 (dvr, mip, iso, shaded, precomputed gradients): float32 rounding of the
# framed rays and boxes, which differ from the ordinary ones in the last bits.
PICTURE_TOLERANCE = 1e-4
DEPTH_TOLERANCE = 1e-5  # window depth (measured up to 6e-7) and the distance's relative error (1.5e-6)


def ball() -> np.ndarray:
    z, y, x = np.mgrid[0:N, 0:N, 0:N]
    radius = np.sqrt((x - 11.5) ** 2 + (y - 10.5) ** 2 + (z - 12.0) ** 2)  # off-centre: orientation shows
    return np.clip(1.0 - radius / 12.0, 0.0, 1.0).astype(np.float32)


BALL = ball()
MODES = {"dvr": {"compositing": "dvr"}, "mip": {"compositing": "mip"},
         "iso shaded": {"compositing": "iso", "shading": "blinn_phong"}}
# (spacing, origin): tiny, anisotropic and tiny off the origin, ~1e14 across, far out, a unit box
# 1e9 from the origin, and spacings at the float64 limit of check_box (1e-12 of the distance).
EXTREME = {"1e-15 spacing": ((1e-15,) * 3, (0.0, 0.0, 0.0)),
           "anisotropic 1e-12": ((1e-12, 2e-12, 1e-12), (3e-12, 0.0, -1e-11)),
           "1e14 across": ((4e12,) * 3, (0.0, 0.0, 0.0)),
           "1e14 across, off centre": ((4e12,) * 3, (-4e14, 1e14, 0.0)),
           "far out": ((1e12,) * 3, (5e14, 5e14, -5e14)),
           "unit voxels 1e9 out": ((1.0,) * 3, (1e9, 0.0, 0.0)),
           "1e-14 spacing at 0.01": ((1e-14,) * 3, (-1e-2, 0.0, 0.0)),
           "1e3 spacing at 9.4e14": ((1e3,) * 3, (9.4e14, -1e14, 4.4e13))}


def network_of(volume: Volume, camera: Camera = DEFAULT_CAMERA, processor="RayCaster", **properties):
    return ray_caster_network(volume, camera, processor, **properties)


def render(volume: Volume, mode: dict, camera: Camera = DEFAULT_CAMERA):
    """(image, depth) of the RayCaster; no warning may come (a blank image would warn)."""
    network = network_of(volume, camera, **mode)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return network.evaluate("rc.image", size=SIZE), network.evaluate("rc.depth", size=SIZE)


def ordinary(spacing) -> Volume:
    """The ball with the extreme volume's spacing ratios, its smallest spacing 1, at the origin."""
    return Volume(BALL, spacing=tuple(s / min(spacing) for s in spacing))


def write_ball(folder, name="ball.npy") -> str:
    path = folder / name
    np.save(path, BALL)
    return str(path)


def run(folder, *options) -> tuple[int, str]:
    output = str(folder / "out.png")
    return main(["run", write_ball(folder), "-o", output, *options]), output


# --- refused by name ------------------------------------------------------------------------------
def test_vgraph_run_refuses_a_box_beyond_1e15_naming_the_property_and_file(tmp_path, capsys):
    """24 voxels of spacing 1e14 span 2.3e15: before, pydantic's ValidationError for Camera, exit 1."""
    code, _ = run(tmp_path, "--set", "source.spacing=[1e14,1e14,1e14]")
    err = capsys.readouterr().err
    assert code == 2
    assert "source.spacing: " in err and "ball.npy" in err and "reaches 2.3e+15" in err
    assert "ValidationError" not in err and "Traceback" not in err


@pytest.mark.parametrize("meta", [{"spacing": [1e14, 1e14, 1e14]},
                                  {"spacing": [1e13, 1.0, 1.0], "origin": [9e14, 0.0, 0.0]},
                                  {"spacing": [1e-15, 1e-15, 1e-15], "origin": [1e3, 0.0, 0.0]}])
def test_a_file_whose_grid_cannot_be_drawn_is_refused_naming_file_and_field(tmp_path, meta):
    """Beyond +-1e15, or a spacing under 1e-12 of the box's distance from the origin (the voxel
    centres merge in float64; before, a blank image whose warning blamed the camera)."""
    path = tmp_path / "ball.npz"
    np.savez(path, data=BALL, **meta)
    with pytest.raises(VolumeFileError, match=r"ball\.npz \[spacing\]: .*(reaches|too small)") as caught:
        read_volume(path)
    assert caught.value.field == "spacing"


def test_volumes_and_bricked_volumes_refuse_such_grids():
    with pytest.raises(VolumeGeometryError, match=r"reaches 1\.03e\+15: beyond \+-1e\+15"):
        Volume(BALL, spacing=(1.0, 1.0, 1e13), origin=(0.0, 0.0, 8e14))
    with pytest.raises(VolumeGeometryError, match="too small for a box 1e\\+03 from the origin"):
        Volume(BALL, spacing=(1e-15,) * 3, origin=(1e3, 0.0, 0.0))
    bricks = ArrayPyramid.from_volume(Volume(BALL), (8, 8, 8))
    with pytest.raises(VolumeGeometryError, match="reaches 2.3e\\+15"):
        BrickedVolume(bricks, spacing=(1e14,) * 3)
    assert BrickedVolume(bricks, spacing=(4e12,) * 3).spacing == (4e12,) * 3  # 9.2e13 across: drawn


# --- extreme but valid: the ordinary picture ----------------------------------------------------
@pytest.mark.parametrize("spacing", [1e-12, 1e-15, 4e13])
def test_vgraph_run_renders_an_extreme_ball_as_the_ordinary_one(tmp_path, capsys, spacing):
    """Before, 1e-12 and 1e-15: a blank image and a warning that blamed the camera (the fit-to-data
    camera framed a sphere of at least 1e-6, a million times the ball); 4e13 (9.2e14 across, a
    valid box): pydantic's ValidationError for Camera, exit 1 (the framing camera lay beyond 1e15)."""
    code, expected = run(tmp_path)
    assert code == 0
    expected_pixels = np.asarray(PILImage.open(expected)).astype(int)
    capsys.readouterr()
    code, output = run(tmp_path, "--set", f"source.spacing=[{spacing},{spacing},{spacing}]")
    assert code == 0 and "empty image" not in capsys.readouterr().err
    assert expected_pixels[..., :3].max() > 100
    assert np.abs(np.asarray(PILImage.open(output)).astype(int) - expected_pixels).max() <= 1


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("geometry", EXTREME)
def test_extreme_but_valid_volumes_render_the_picture_and_depth_of_the_ordinary_one(geometry, mode):
    """The default camera fits the data, so every scaled and moved copy of the ball frames alike.
    The depth output stays in world units: window depth as the ordinary volume's, distance scaled."""
    spacing, origin = EXTREME[geometry]
    expected, expected_depth = render(ordinary(spacing), MODES[mode])
    image, depth = render(Volume(BALL, spacing=spacing, origin=origin), MODES[mode])
    assert expected[..., :3].max() > 0.3
    assert np.abs(image - expected).max() < PICTURE_TOLERANCE
    hit = expected_depth[..., 3] == 1.0
    assert hit.sum() > 100 and np.array_equal(depth[..., 3] == 1.0, hit)
    assert np.abs(depth[..., 0] - expected_depth[..., 0])[hit].max() < DEPTH_TOLERANCE
    world = expected_depth[..., 1][hit] * min(spacing)
    assert np.abs(depth[..., 1][hit] / world - 1.0).max() < DEPTH_TOLERANCE


def test_shading_from_precomputed_gradients_and_opacity_correction_are_unchanged_in_the_frame():
    spacing, origin = EXTREME["anisotropic 1e-12"]
    for mode in ({"compositing": "iso", "shading": "blinn_phong", "derivatives": "precomputed"},
                 {"compositing": "dvr", "shading": "blinn_phong", "sampling_rate": 2.0}):
        expected, _ = render(ordinary(spacing), mode)
        image, _ = render(Volume(BALL, spacing=spacing, origin=origin), mode)
        assert np.abs(image - expected).max() < PICTURE_TOLERANCE


def test_ordinary_volumes_are_drawn_in_world_units_as_before():
    """The identity frame: the volume itself, the camera view_camera resolves (the same object), the
    depth distance unscaled; a box just large enough for world units stays there."""
    volume = Volume(BALL, spacing=(0.5, 0.5, 1.0), origin=(-3.0, 2.0, 100.0))
    view = framed_view(DEFAULT_CAMERA, (volume,), SIZE, "rc")
    assert view.frame.is_identity and view.volumes[0] is volume
    assert view.camera is view_camera(DEFAULT_CAMERA, volume, SIZE) is view.world_camera
    network = network_of(volume)
    network.evaluate("rc.image", size=SIZE)
    assert network["rc"].view_camera is network["eep"].view_camera is view.camera

    def frame_of(extent):
        return framed_view(DEFAULT_CAMERA, (Volume(BALL, spacing=(extent / 23,) * 3),), SIZE, "rc").frame
    assert frame_of(2e-5).is_identity and not frame_of(1e-6).is_identity


def test_the_view_camera_is_in_world_units_and_frame_volume_stores_it():
    """framed, the GUI's camera still looks at the volume where it is; stored by frame_volume(),
    it renders the same picture (moved into the frame again)."""
    spacing, origin = (1e-12,) * 3, (5e-12, -2e-11, 0.0)
    volume = Volume(BALL, spacing=spacing, origin=origin)
    network = network_of(volume)
    fitted = network.evaluate("rc.image", size=SIZE)
    assert fitted[..., :3].max() > 0.3
    camera = network["rc"].view_camera
    assert not camera.fit_to_data
    np.testing.assert_allclose(camera.focus, np.add(origin, 11.5e-12), rtol=1e-9)
    network["eep"].frame_volume()
    assert network.get("rc.camera") == network.get("eep.camera") and not network.get("eep.camera").fit_to_data
    assert np.abs(network.evaluate("rc.image", size=SIZE) - fitted).max() < PICTURE_TOLERANCE


def test_a_box_whose_framing_camera_lies_beyond_1e15_renders_without_a_world_camera():
    """9.2e14 across: the framed camera stands 3e15 away in world units, more than a Camera holds.
    The picture is drawn in the frame; view_camera is None and frame_volume() says why."""
    spacing = (4e13,) * 3
    expected, _ = render(ordinary(spacing), MODES["dvr"])
    network = network_of(Volume(BALL, spacing=spacing), **MODES["dvr"])
    assert np.abs(network.evaluate("rc.image", size=SIZE) - expected).max() < PICTURE_TOLERANCE
    assert network["rc"].view_camera is None and network["eep"].view_camera is None
    with pytest.raises(vgraph.VGraphError, match=r"eep\.camera: a camera framing the box .* beyond \+-1e15"):
        network["eep"].frame_volume()


def test_a_camera_that_cannot_view_an_ordinary_box_is_refused_naming_the_camera():
    """Its automatic far plane would lie beyond 1e15: before, pydantic's ValidationError (exit 1)."""
    camera = Camera(position=(9.995e14, 0.0, 0.0), focus=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0))
    network = network_of(Volume(BALL), camera)
    with pytest.raises(vgraph.VGraphError, match=r"eep\.camera: cannot view the box .* less than or equal"):
        network.evaluate("rc.image", size=SIZE)


def test_a_stored_camera_far_from_a_tiny_box_sees_a_speck_and_says_so():
    """Too far to be held in the box's frame, the camera is resolved in world units: no error, the
    ball is below a pixel, and the blank image is reported."""
    network = network_of(Volume(BALL, spacing=(1e-14,) * 3), Camera(position=(0.0, 0.0, 100.0)))
    with pytest.warns(BlankImageWarning, match=r"rc \(RayCaster\) rendered an empty image"):
        network.evaluate("rc.image", size=SIZE)


def test_clip_planes_and_the_crop_box_cut_an_extreme_volume_where_they_cut_the_ordinary_one():
    scale, shift = 1e-12, np.array([4e-10, 0.0, -1e-10])

    def cut(spacing, at):
        network = network_of(Volume(BALL, spacing=(spacing,) * 3, origin=tuple(at((0.0, 0.0, 0.0)))))
        plane = ClipPlane(normal=(1.0, 0.3, 0.0), point=tuple(at((12.0, 11.0, 12.0))))
        network.set("eep.clip_planes", [plane])
        network.set("eep.crop_box", (*at((-1.0, -1.0, 4.0)), *at((30.0, 30.0, 30.0))))
        return network.evaluate("rc.image", size=SIZE)
    expected = cut(1.0, lambda p: np.asarray(p, dtype=float))
    whole, _ = render(Volume(BALL), MODES["dvr"])
    assert np.abs(expected - whole).max() > 0.3  # the cut shows
    assert np.abs(cut(scale, lambda p: np.asarray(p) * scale + shift) - expected).max() < PICTURE_TOLERANCE


def test_tiles_of_an_extreme_volume_are_the_whole_pictures_rectangles_bit_for_bit():
    volume = Volume(BALL, spacing=(4e12,) * 3, origin=(-4e14, 1e14, 0.0))
    camera = Camera(**{**DEFAULT_CAMERA.model_dump(), "position": (1.0, 2.0, 3.0), "focus": (0.0, 0.0, 0.0)})
    whole = network_of(volume, camera).evaluate("rc.image", size=(48, 32))
    for x, y, w, h in ((0, 0, 24, 16), (24, 16, 24, 16), (5, 9, 30, 13)):
        tile = network_of(volume, camera.tile(x, y, w, h, 48, 32)).evaluate("rc.image", size=(w, h))
        assert np.array_equal(tile, whole[y:y + h, x:x + w])


# --- the other ray casters -------------------------------------------------------------------------
def test_the_multi_volume_ray_caster_draws_extreme_channels_in_their_union_frame():
    """Two channels on different grids, their union box moved and scaled into its frame."""
    from helpers.multivolume import BLUE, ORANGE

    def image(scale, shift):
        a = Volume(BALL, spacing=(scale,) * 3, origin=tuple(shift))
        b = Volume(BALL[::2, ::2, ::2].copy(), spacing=(2 * scale,) * 3, origin=tuple(shift + 6 * scale))
        network = vgraph.Network()
        network.add(GivenVolume(id="a", volume=a))
        network.add(GivenVolume(id="b", volume=b))
        network.add("EntryExitPoints", id="eep")
        network.add("MultiVolumeRayCaster", id="mv", transfer_function1=ORANGE, transfer_function2=BLUE,
                    shading="blinn_phong")
        network.link("eep.camera", "mv.camera")
        for source, target in (("a.volume", "eep.volume"), ("b.volume", "eep.volume2"),
                               ("a.volume", "mv.volume1"), ("b.volume", "mv.volume2"),
                               ("eep.entry", "mv.entry"), ("eep.exit", "mv.exit")):
            network.connect(source, target)
        return network.evaluate("mv.image", size=SIZE)
    expected = image(1.0, np.zeros(3))
    assert expected[..., :3].max() > 0.3
    for scale, shift in ((1e-13, np.array([1e-11, 0.0, 0.0])), (3e12, np.array([-6e14, 0.0, 2e14]))):
        assert np.abs(image(scale, shift) - expected).max() < PICTURE_TOLERANCE


@pytest.mark.parametrize("bricked", [False, True])
def test_the_bricked_ray_caster_draws_an_extreme_volume_brick_by_brick_in_its_frame(bricked):
    """An in-memory volume (its ArrayPyramid is the framed copy's) and a BrickedVolume (regridded,
    nothing read) alike."""
    def image(spacing, origin):
        volume = Volume(BALL, spacing=spacing, origin=origin)
        if bricked:
            volume = BrickedVolume(ArrayPyramid.from_volume(Volume(BALL), (8, 8, 8)), spacing=spacing,
                                   origin=origin)
        network = network_of(volume, processor="BrickedRayCaster", brick_size=8, compositing="dvr")
        return network.evaluate("rc.image", size=SIZE)
    expected = image((1.0,) * 3, (0.0, 0.0, 0.0))
    assert expected[..., :3].max() > 0.3
    for spacing, origin in (EXTREME["1e-15 spacing"], EXTREME["far out"]):
        assert np.abs(image(spacing, origin) - expected).max() < PICTURE_TOLERANCE


def test_the_label_ray_caster_draws_an_extreme_label_volume_in_its_frame():
    labels = (BALL > 0.3).astype(np.uint8) + (BALL > 0.6).astype(np.uint8)

    def image(spacing, origin):
        network = network_of(Volume(labels, spacing=spacing, origin=origin), processor="LabelRayCaster",
                             id="rc", inport="labels", shading="blinn_phong")
        return network.evaluate("rc.image", size=SIZE)
    for geometry in ("anisotropic 1e-12", "far out"):
        spacing, origin = EXTREME[geometry]
        expected = image(ordinary(spacing).spacing, (0.0, 0.0, 0.0))
        assert expected[..., :3].max() > 0.3
        assert np.abs(image(spacing, origin) - expected).max() < PICTURE_TOLERANCE


@pytest.mark.parametrize("processor", ["CurvatureRaycaster", "CurvatureVolumeRaycaster"])
def test_curvature_ray_casters_refuse_an_extreme_box_by_name(processor):
    """Their curvatures, positions and attenuation are world lengths: refused, not drawn wrong."""
    network = network_of(Volume(BALL, spacing=(1e-12,) * 3, source="tiny.npy"), processor=processor,
                         derivatives="central")
    with pytest.raises(vgraph.VGraphError, match=r"rc\.volume: tiny\.npy spans .* a box this ray caster "
                                                 r"cannot draw"):
        network.evaluate("rc.image", size=SIZE)
    assert network_of(Volume(BALL), processor=processor, derivatives="central").evaluate(
        "rc.image", size=SIZE)[..., :3].max() > 0.1


def test_opaque_geometry_mixes_with_an_extreme_volume_as_with_the_ordinary_one():
    """GeometryRenderer (with the volume) -> GeometryEntryExit -> RayCaster: the sphere is drawn in
    the volume's frame, its depth distance stays in world units and cuts the rays where it is."""
    from helpers.geometry import GivenGeometry
    from vgraph.geometry import Geometry

    def image(scale, shift):
        fog = Volume(np.full((12, 16, 14), 0.5, np.float32), spacing=(scale,) * 3, origin=tuple(shift))
        sphere = Geometry.sphere(shift + scale * np.array([6.5, 7.5, 5.5]), 4.0 * scale, subdivisions=4)
        network = vgraph.Network()
        network.add(GivenVolume(id="src", volume=fog))
        network.add(GivenGeometry(id="mesh", geometry=sphere))
        network.add("EntryExitPoints", id="eep")
        network.add("RayCaster", id="rc", early_termination=1.0, background=(0.0, 0.0, 0.0, 0.0),
                    transfer_function={"points": [[0.0, 0.0, 0.0, 1.0, 0.05], [1.0, 0.0, 0.0, 1.0, 0.05]]})
        network.add("GeometryRenderer", id="gr", shading="none", color=(1.0, 0.0, 0.0, 1.0))
        network.add("GeometryEntryExit", id="gee")
        network.add("ImageCompositor", id="mix")
        for follower in ("rc.camera", "gr.camera", "gee.camera"):
            network.link("eep.camera", follower)
        for source, target in (("mesh.geometry", "gr.geometry"), ("src.volume", "gr.volume"),
                               ("src.volume", "eep.volume"), ("src.volume", "rc.volume"),
                               ("src.volume", "gee.volume"), ("eep.entry", "gee.entry"),
                               ("eep.exit", "gee.exit"), ("gr.depth", "gee.depth"), ("gee.entry", "rc.entry"),
                               ("gee.exit", "rc.exit"), ("rc.image", "mix.front"), ("gr.image", "mix.back")):
            network.connect(source, target)
        return network.evaluate("mix.image", size=SIZE)
    expected = image(1.0, np.zeros(3))
    red = expected[..., 0] > 0.3
    assert red.sum() > 100 and (expected[..., 2] > 0.3).sum() > 100  # the sphere, dimmed by fog in front
    for scale, shift in ((1e-12, np.array([3e-12, 0.0, -1e-11])), (1e12, np.array([5e14, -2e14, 0.0]))):
        assert np.abs(image(scale, shift) - expected).max() < PICTURE_TOLERANCE


def test_framed_copies_and_their_textures_go_with_their_volumes():
    """One copy per volume, kept only while the volume lives: rendering new extreme volumes (with
    a gradient volume, skipping blocks and ray bounds of each copy) leaves no GL texture behind."""
    import gc

    from vgraph.gl_context import collect_garbage, get_context
    from vgraph.leaks import live_gl_textures

    def textures_after_rendering() -> int:
        volume = Volume(BALL, spacing=(1e-12,) * 3, origin=(0.0, 5e-11, 0.0))
        network = network_of(volume, compositing="iso", shading="blinn_phong", derivatives="precomputed",
                             ray_bounds=True)
        assert network.evaluate("rc.image", size=SIZE)[..., :3].max() > 0.3
        del network, volume
        gc.collect()
        collect_garbage()
        return live_gl_textures(get_context())
    counts = [textures_after_rendering() for _ in range(6)]
    assert counts[-1] <= counts[1], counts
