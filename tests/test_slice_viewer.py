"""SliceViewer: axis-aligned slices equal numpy's slices of the array, arbitrary planes equal
scipy.ndimage.map_coordinates (nearest, linear, cubic B-spline), window/level numbers in data
values, the transfer function's colours, the pixel -> world map a click uses, transparent pixels
outside the volume, and clear errors for impossible properties."""

import numpy as np
import pytest
from scipy import ndimage

from vgraph import Network, PropertyError, VGraphError
from vgraph.cli import main
from vgraph.gl.shaders import programs
from vgraph.processors.slice_viewer import SliceViewer
from vgraph.slicing import plane_axes
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.paths import DATA, REPO

# Measured on llvmpipe: nearest 8e-8 (float32 normalisation), linear at voxel centres 1.8e-7, on
# an oblique plane 4.9e-7 (float32 voxel coordinates and filter weights), cubic 6.1e-7.
EXACT = 1e-6
TOLERANCE = 2e-5
SHAPE = (6, 7, 9)  # (z, y, x)


def random_volume(spacing=(1.5, 1.5, 1.5), dtype=np.float32, seed=0) -> Volume:
    data = np.random.default_rng(seed).random(SHAPE)
    if dtype == np.uint16:
        data = np.round(data * 4000).astype(np.uint16)
    return Volume(data.astype(dtype), spacing=spacing, origin=(3.0, -2.0, 1.0))


def slice_image(volume: Volume, size, **properties) -> tuple[np.ndarray, SliceViewer]:
    viewer = SliceViewer("slice", **properties)
    viewer.render_size = tuple(size)
    return viewer.process(volume).to_numpy(), viewer


def reference(volume: Volume, viewer: SliceViewer, size, order: int) -> np.ndarray:
    """The CPU slice: world points of the pixel centres (the viewer's own map, tested below against
    voxel positions) sampled by scipy.ndimage.map_coordinates, as grey in the default window (the
    value range; the cubic spline overshoots it); 0 outside the voxels' cells."""
    width, height = size
    columns, rows = np.meshgrid(np.arange(width), np.arange(height))
    voxel = volume.world_to_voxel(viewer.pixel_to_world(columns, rows))  # (h, w, 3) as (x, y, z)
    data = volume.normalized(volume.data)
    # Linear: clamp to the edge voxel in the outer half cell, as GL's clamp-to-edge; the cubic
    # spline mirrors the coefficients at the boundary like numerics.bspline.
    mode = "mirror" if order == 3 else "nearest"
    if order == 0:
        voxel = np.floor(voxel + 0.5)
    values = ndimage.map_coordinates(data, voxel[..., ::-1].transpose(2, 0, 1), order=order, mode=mode)
    inside = np.all((voxel >= -0.5) & (voxel <= np.array(volume.dims) - 0.5), axis=-1)
    return np.where(inside, np.clip(values, 0.0, 1.0), 0.0)  # the default window: the value range


# --- axis-aligned slices are the array's slices ---------------------------------------------------
@pytest.mark.parametrize("interpolation", ["nearest", "linear", "cubic"])
def test_axis_aligned_slices_at_voxel_centres_are_the_numpy_slices(interpolation):
    volume = random_volume()
    values = volume.normalized(volume.data)
    if interpolation == "cubic":  # the spline interpolates: at voxel centres it is the voxels
        values = ndimage.map_coordinates(values, np.indices(SHAPE), order=3, mode="mirror")
    nz, ny, nx = SHAPE
    i, j, k = 2, 5, 4
    cursor = tuple(volume.voxel_to_world((i, j, k)))
    # Image right/up: axial -x/+y, coronal -x/+z, sagittal -y/+z (row 0 at the top).
    expected = {"axial": ((nx, ny), values[k, ::-1, ::-1]),
                "coronal": ((nx, nz), values[::-1, j, ::-1]),
                "sagittal": ((ny, nz), values[::-1, ::-1, i])}
    for orientation, (size, numpy_slice) in expected.items():
        image, _ = slice_image(volume, size, orientation=orientation, cursor=cursor,
                               interpolation=interpolation)
        np.testing.assert_allclose(image[..., 0], numpy_slice, atol=EXACT, rtol=0, err_msg=orientation)
        np.testing.assert_array_equal(image[..., 3], 1.0)


def test_named_orientations_are_the_custom_planes_of_the_named_views_eye_directions():
    volume = random_volume()
    for orientation, normal in {"axial": (0, 0, -1), "coronal": (0, 1, 0), "sagittal": (-1, 0, 0)}.items():
        named, _ = slice_image(volume, (20, 16), orientation=orientation)
        custom, _ = slice_image(volume, (20, 16), orientation="custom", normal=normal)
        np.testing.assert_array_equal(named, custom)
        n, right, up = plane_axes(orientation)
        np.testing.assert_allclose(np.cross(right, up), n)  # right-handed: right x up towards the eye


# --- arbitrary planes are scipy's interpolation -----------------------------------------------------
@pytest.mark.parametrize("interpolation, order", [("nearest", 0), ("linear", 1), ("cubic", 3)])
def test_an_oblique_plane_equals_map_coordinates(interpolation, order):
    volume = random_volume(spacing=(1.2, 0.7, 2.0), dtype=np.uint16, seed=3)
    size = (48, 36)
    image, viewer = slice_image(volume, size, orientation="custom", normal=(1.0, 2.0, 3.0),
                                cursor=(7.0, 1.0, 5.5), zoom=1.3, interpolation=interpolation)
    expected = reference(volume, viewer, size, order)
    inside = image[..., 3] > 0
    assert 0.3 < inside.mean() < 1.0  # the plane crosses the volume and leaves some pixels outside
    np.testing.assert_allclose(image[..., 0], expected, atol=EXACT if order == 0 else TOLERANCE, rtol=0)


def test_anisotropic_coronal_slice_is_in_world_units():
    """Spacing (1, 1, 3): a coronal image of 9 x 6 voxels spans 9 by 18 world units, so at
    square pixels it is twice as tall as wide and each voxel row covers three pixel rows."""
    volume = Volume(np.random.default_rng(1).random(SHAPE).astype(np.float32), spacing=(1.0, 1.0, 3.0))
    image, viewer = slice_image(volume, (9, 18), orientation="coronal",
                                cursor=tuple(volume.voxel_to_world((0, 3, 0))), interpolation="nearest")
    values = volume.normalized(volume.data)[::-1, 3, ::-1]
    np.testing.assert_allclose(image[..., 0], np.repeat(values, 3, axis=0), atol=EXACT)
    np.testing.assert_allclose(np.linalg.norm(viewer.last_plane.right), 9.0)
    np.testing.assert_allclose(np.linalg.norm(viewer.last_plane.up), 18.0)


# --- pixels <-> world ---------------------------------------------------------------------------------
def test_pixel_to_world_puts_pixel_centres_on_voxel_centres():
    volume = random_volume()
    nz, ny, nx = SHAPE
    _, viewer = slice_image(volume, (nx, ny), orientation="axial",
                            cursor=tuple(volume.voxel_to_world((0, 0, 4))))
    for column, row in [(0, 0), (3, 5), (nx - 1, ny - 1)]:
        np.testing.assert_allclose(viewer.pixel_to_world(column, row),
                                   volume.voxel_to_world((nx - 1 - column, ny - 1 - row, 4)))
    uv = viewer.last_plane.uv_of(viewer.pixel_to_world(2, 1))
    np.testing.assert_allclose(uv, [(2 + 0.5) / nx, 1 - (1 + 0.5) / ny])


def test_zoom_magnifies_about_the_cursor():
    volume = random_volume()
    cursor = (6.0, 3.0, 4.0)
    planes = [slice_image(volume, (64, 48), orientation="coronal", cursor=cursor, zoom=zoom)[1].last_plane
              for zoom in (1.0, 2.5)]
    np.testing.assert_allclose(planes[0].uv_of(cursor), planes[1].uv_of(cursor))  # stays put
    np.testing.assert_allclose(np.linalg.norm(planes[0].right) / np.linalg.norm(planes[1].right), 2.5)


def test_a_plane_outside_the_volume_is_an_empty_image_and_the_border_is_transparent():
    volume = random_volume()
    image, _ = slice_image(volume, (16, 16), orientation="axial", cursor=(0.0, 0.0, 100.0))
    np.testing.assert_array_equal(image, 0.0)
    image, _ = slice_image(volume, (32, 32), orientation="axial", zoom=0.5)
    np.testing.assert_array_equal(image[0, 0], 0.0)  # transparent black around the volume
    assert image[16, 16, 3] == 1.0


def test_the_outline_is_where_the_plane_cuts_the_volumes_box():
    volume = random_volume(spacing=(1.2, 0.7, 2.0))
    low = np.array(volume.origin) - 0.5 * np.array(volume.spacing)
    high = low + np.array(volume.dims) * np.array(volume.spacing)
    _, axial = slice_image(volume, (16, 16), orientation="axial", cursor=(5.0, 0.0, 4.0))
    outline = axial.last_plane.outline()
    expected = [[high[0], low[1], 4.0], [low[0], low[1], 4.0], [low[0], high[1], 4.0], [high[0], high[1], 4.0]]
    np.testing.assert_allclose(outline, expected)  # counter-clockwise in the image, from bottom left
    _, oblique = slice_image(volume, (16, 16), orientation="custom", normal=(1.0, 2.0, 3.0),
                             cursor=(7.0, 1.0, 5.5))
    plane, outline = oblique.last_plane, oblique.last_plane.outline()
    assert 3 <= len(outline) <= 6
    np.testing.assert_allclose((outline - (7.0, 1.0, 5.5)) @ plane.normal, 0.0, atol=1e-9)  # on the plane
    on_faces = np.isclose(outline, low) | np.isclose(outline, high)
    assert on_faces.any(axis=1).all()  # on the box's surface
    assert np.all((outline >= low - 1e-9) & (outline <= high + 1e-9))
    _, missing = slice_image(volume, (16, 16), orientation="axial", cursor=(0.0, 0.0, 100.0))
    assert missing.last_plane.outline().shape == (0, 3)


# --- mapping --------------------------------------------------------------------------------------------
def test_window_centre_and_width_are_data_values():
    values = np.array([500, 700, 900, 1000, 1100, 1300, 2000])
    volume = Volume(np.broadcast_to(values.astype(np.uint16), (2, 3, 7)).copy())  # x along values
    image, _ = slice_image(volume, (7, 3), orientation="axial", interpolation="nearest",
                           window=(1000.0, 400.0))
    # axial is seen from below: x runs right to left; window 800..1200
    np.testing.assert_allclose(image[1, ::-1, 0], [0.0, 0.0, 0.25, 0.5, 0.75, 1.0, 1.0], atol=EXACT)
    np.testing.assert_allclose(image[..., 1], image[..., 0])
    whole, _ = slice_image(volume, (7, 3), orientation="axial", interpolation="nearest")
    np.testing.assert_allclose(whole[1, ::-1, 0], (values - 500) / 1500, atol=EXACT)  # the value range


def test_tf_mapping_gives_the_transfer_functions_colour_and_opacity():
    volume = random_volume(dtype=np.uint16, seed=5)
    tf = TransferFunction(points=[(0.0, 1.0, 0.0, 0.0, 0.2), (1.0, 0.0, 0.5, 1.0, 0.9)])
    nz, ny, nx = SHAPE
    image, _ = slice_image(volume, (nx, ny), orientation="axial", interpolation="nearest",
                           mapping="tf", transfer_function=tf,
                           cursor=tuple(volume.voxel_to_world((0, 0, 2))))
    n = volume.normalized(volume.data[2, ::-1, ::-1])[..., None]
    expected = (1 - n) * np.array([1.0, 0.0, 0.0, 0.2]) + n * np.array([0.0, 0.5, 1.0, 0.9])
    np.testing.assert_allclose(image, expected, atol=TOLERANCE)


def test_the_crosshair_marks_the_cursor_row_and_column():
    volume = random_volume()
    nz, ny, nx = SHAPE
    image, _ = slice_image(volume, (nx, ny), orientation="axial", crosshair=True,
                           crosshair_color=(0.0, 1.0, 0.0, 1.0),
                           cursor=tuple(volume.voxel_to_world((2, 5, 3))))
    green = np.all(image == [0.0, 1.0, 0.0, 1.0], axis=-1)
    column, row = nx - 1 - 2, ny - 1 - 5
    assert green[:, column].all() and green[row, :].all() and green.sum() == nx + ny - 1


# --- errors -------------------------------------------------------------------------------------------
def test_impossible_properties_are_refused_naming_the_field():
    volume = random_volume()
    with pytest.raises(VGraphError, match=r"slice\.normal: the normal \(0\.0, 0\.0, 0\.0\) has no direction"):
        slice_image(volume, (8, 8), orientation="custom", normal=(0.0, 0.0, 0.0))
    with pytest.raises(VGraphError, match=r"slice\.window: the width .* must be positive"):
        slice_image(volume, (8, 8), window=(100.0, 0.0))
    with pytest.raises(PropertyError, match="slice.orientation"):
        SliceViewer("slice", orientation="oblique")
    with pytest.raises(PropertyError, match="slice.zoom"):
        SliceViewer("slice", zoom=0.0)
    with pytest.raises(VGraphError, match="B-spline coefficients"):
        slice_image(volume.with_data(volume.data, is_spline_coefficients=True), (8, 8))
    with pytest.raises(VGraphError, match="no slice drawn yet"):
        SliceViewer("slice").pixel_to_world(0, 0)


def test_a_network_file_with_a_zero_normal_does_not_validate(tmp_path):
    net = Network()
    net.add("VolumeSource", id="source", path=str(REPO / "networks" / "data" / "engine_labels.nrrd"))
    net.add("SliceViewer", id="slice", orientation="custom", normal=(0.0, 0.0, 0.0))
    net.add("Canvas", id="canvas")
    net.connect("source.volume", "slice.volume")
    net.connect("slice.image", "canvas.image")
    net.save(tmp_path / "bad.json")
    assert main(["validate", str(tmp_path / "bad.json")]) != 0


def test_only_the_chosen_interpolation_and_mapping_are_compiled():
    volume = random_volume()
    viewer = SliceViewer("slice")
    viewer.render_size = (16, 16)
    programs.clear()

    def compiles(**changes):
        before = programs.compile_count
        for name, value in changes.items():
            viewer.set_property(name, value)
        viewer.process(volume)
        return programs.compile_count - before

    assert compiles() == 1
    assert compiles(cursor=(4.0, 2.0, 3.0), window=(0.5, 0.2), zoom=2.0, orientation="sagittal") == 0
    assert compiles(interpolation="cubic") == 1
    assert compiles(mapping="tf") == 1
    assert compiles(interpolation="linear", mapping="window") == 0  # cached


def test_the_mpr_network_runs_from_the_cli(tmp_path):
    if not DATA.is_dir():
        pytest.skip(f"shared data sets not found at {DATA}")
    out = tmp_path / "coronal.npy"
    assert main(["run", str(REPO / "networks" / "mpr_mri_head.json"), "--port", "coronal.image",
                 "--size", "64x64", "--data", str(out)]) == 0
    image = np.load(out)
    # The head's box is 160 x 143.7 world units across x and z: full width, transparent rows
    # above and below. The network draws no crosshair into the image (the GUI draws it on screen).
    assert image.shape == (64, 64, 4)
    assert np.all(image[0, :20, 3] == 0.0) and image[32, 10, 3] == 1.0
    np.testing.assert_allclose(image[32, 10, :3], image[32, 10, 0])  # grey in the window
