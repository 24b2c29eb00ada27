"""Slices of oriented volumes (issue 28): the SliceViewer samples world -> voxel through the
volume's affine. A DICOM axial CT slice drawn at its own size is pydicom's pixel_array in
radiological display (its neurological display the mirror image); an LPS-stored and a RAS-stored
copy of the same head (made with nibabel) give the same slices; a volume tilted 35 degrees about x
gives the tilted anatomy (scipy.ndimage.map_coordinates at the same world points); the cells' box,
the default cursor, the framing, the outline and the wheel's step follow the oriented box."""

from pathlib import Path

import nibabel as nib
import numpy as np
import pydicom
import pytest
from pydicom.pixels import apply_modality_lut
from scipy import ndimage

from vgraph import VGraphError
from vgraph.gui.slice_gestures import page_step
from vgraph.io import read_volume
from vgraph.processors.slice_viewer import SliceViewer
from vgraph.slicing import GridBox, plane_axes
from vgraph.volume import Volume
from vgraph.volume_grid import IDENTITY

from helpers.dicom import write_ct_slice

MRI = Path(__file__).parents[1].parent / "shared" / "data" / "mri_head_t1" / "MR.nii.gz"
LPS_TO_RAS = np.diag([-1.0, -1.0, 1.0])
# llvmpipe, float32 voxel coordinates: linear filtering at points off the voxel centres
# (tests/test_slice_viewer.py measured 4.9e-7 on an oblique plane)
TOLERANCE = 2e-5


def slice_image(volume: Volume, size, **properties) -> tuple[np.ndarray, SliceViewer]:
    viewer = SliceViewer("slice", **properties)
    viewer.render_size = tuple(size)
    return viewer.process(volume).to_numpy(), viewer


def rotation_about_x(degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


# --- DICOM: the axial slice is pydicom's array ------------------------------------------------------
def dicom_volume(ds) -> Volume:
    """The slice as a Volume in RAS, as the DICOM reader makes it: index i along the rows'
    cosines, j along the columns', k along their cross product, LPS -> RAS by negating x and y."""
    row, column = np.array(ds.ImageOrientationPatient[:3], float), np.array(ds.ImageOrientationPatient[3:], float)
    direction = LPS_TO_RAS @ np.column_stack([row, column, np.cross(row, column)])
    spacing = (float(ds.PixelSpacing[1]), float(ds.PixelSpacing[0]), float(ds.SliceThickness))
    origin = LPS_TO_RAS @ np.array(ds.ImagePositionPatient, float)
    return Volume(ds.pixel_array[None], spacing=spacing, origin=tuple(origin), direction=direction)


@pytest.fixture
def ct_slice(tmp_path):
    pixels = np.random.default_rng(7).integers(-1000, 3000, size=(24, 32)).astype(np.int16)
    pixels[2:5, 3:9] = 3000  # a mark near the top left: a flip of either axis moves it
    write_ct_slice(tmp_path / "ct.dcm", pixels)
    ds = pydicom.dcmread(tmp_path / "ct.dcm")
    return ds, dicom_volume(ds)


@pytest.mark.parametrize("interpolation", ["nearest", "linear"])
@pytest.mark.parametrize("route", ["Volume", "read_volume"])
def test_a_dicom_axial_slice_at_its_own_size_is_pydicoms_array_in_radiological_display(
        ct_slice, tmp_path, interpolation, route):
    """Built from the tags here, or read by vgraph's DICOM reader (which applies the rescale to
    Hounsfield units, as pydicom's apply_modality_lut does)."""
    ds, volume = ct_slice
    expected = ds.pixel_array
    if route == "read_volume":
        volume = read_volume(tmp_path / "ct.dcm")
        expected = apply_modality_lut(ds.pixel_array, ds)
    np.testing.assert_array_equal(np.asarray(volume.direction), np.diag([-1.0, -1.0, 1.0]))
    image, _ = slice_image(volume, (ds.Columns, ds.Rows), orientation="axial", interpolation=interpolation)
    lo, hi = volume.value_range  # the default window: the whole value range
    values = np.rint(image[..., 0].astype(np.float64) * (hi - lo) + lo)
    np.testing.assert_array_equal(values, expected)  # row 0 at the top, column 0 at the left
    np.testing.assert_array_equal(image[..., 3], 1.0)


def test_the_neurological_display_is_the_left_right_mirror(ct_slice):
    ds, volume = ct_slice
    size = (ds.Columns, ds.Rows)
    radiological, _ = slice_image(volume, size, orientation="axial", interpolation="nearest")
    neurological, viewer = slice_image(volume, size, orientation="axial", interpolation="nearest",
                                       display="neurological")
    np.testing.assert_array_equal(neurological, radiological[:, ::-1])
    # the patient's right (+x in RAS) is on the image's right
    assert viewer.pixel_to_world(ds.Columns - 1, 0)[0] > viewer.pixel_to_world(0, 0)[0]


@pytest.mark.parametrize("orientation, mirrored", [("axial", True), ("coronal", True), ("sagittal", False)])
def test_displays_differ_by_a_mirror_for_axial_and_coronal_only(orientation, mirrored):
    radiological, neurological = plane_axes(orientation), plane_axes(orientation, display="neurological")
    np.testing.assert_array_equal(neurological[2], radiological[2])  # up is kept
    np.testing.assert_array_equal(neurological[1], -radiological[1] if mirrored else radiological[1])
    np.testing.assert_allclose(np.cross(neurological[1], neurological[2]), neurological[0])  # right-handed


def test_an_unknown_display_is_refused_by_the_property():
    with pytest.raises(VGraphError, match="display"):
        SliceViewer("s", display="surgical")


# --- the same head stored LPS and RAS --------------------------------------------------------------
def volume_of(image: nib.Nifti1Image) -> Volume:
    """A Volume of a nibabel image: its affine's columns split into spacing and direction."""
    affine = image.affine
    spacing = np.linalg.norm(affine[:3, :3], axis=0)
    data = np.ascontiguousarray(np.asarray(image.dataobj, dtype=np.float32).T)  # (x, y, z) -> [z, y, x]
    return Volume(data, spacing=tuple(spacing), origin=tuple(affine[:3, 3]),
                  direction=affine[:3, :3] / spacing)


def nibabel_copies():
    if not MRI.is_file():
        pytest.skip(f"the MRI head is not at {MRI} (the /work/shared checkout is absent)")
    ras = nib.as_closest_canonical(nib.load(MRI))
    lps = ras.as_reoriented(nib.orientations.ornt_transform(nib.orientations.axcodes2ornt("RAS"),
                                                            nib.orientations.axcodes2ornt("LPS")))
    assert nib.aff2axcodes(ras.affine) == ("R", "A", "S") and nib.aff2axcodes(lps.affine) == ("L", "P", "S")
    return ras, lps


@pytest.fixture(scope="module")
def head_copies():
    return tuple(volume_of(image) for image in nibabel_copies())


def test_the_lps_file_read_by_vgraph_gives_the_ras_files_slice(tmp_path):
    """The user's route: both copies saved by nibabel, read by vgraph's NIfTI reader."""
    paths = [tmp_path / "ras.nii", tmp_path / "lps.nii"]
    for image, path in zip(nibabel_copies(), paths):
        nib.save(image, path)
    ras, lps = (read_volume(path) for path in paths)
    size = (232, 160)
    cursor = tuple(ras.voxel_to_world((83, 121, 70)))
    from_ras, _ = slice_image(ras, size, orientation="sagittal", cursor=cursor, interpolation="nearest")
    from_lps, _ = slice_image(lps, size, orientation="sagittal", cursor=cursor, interpolation="nearest")
    assert from_ras[..., 0].std() > 0.1
    np.testing.assert_array_equal(from_lps, from_ras)


def test_the_copies_hold_every_voxel_at_the_same_world_point(head_copies):
    ras, lps = head_copies
    nx, ny, nz = ras.dims
    np.testing.assert_array_equal(lps.data, ras.data[:, ::-1, ::-1])
    np.testing.assert_allclose(lps.voxel_to_world((nx - 1, ny - 1, 0)), ras.voxel_to_world((0, 0, 0)), atol=1e-9)


# Sagittal slices of the head (0.898 mm along y and z) at 232 x 160 pixels put every pixel centre
# on a voxel centre: nearest gives the same voxels bit for bit. Elsewhere the float32 voxel
# coordinates of the two copies differ by rounding (~1e-5 voxels), which nearest turns into another
# voxel where a pixel centre lies on a cells' border: compared with linear interpolation.
@pytest.mark.parametrize("orientation, size, interpolation", [
    ("axial", (160, 232), "linear"), ("coronal", (160, 144), "linear"),
    ("sagittal", (232, 160), "linear"), ("sagittal", (232, 160), "nearest")])
def test_lps_and_ras_copies_of_a_head_give_the_same_slices(head_copies, orientation, size, interpolation):
    ras, lps = head_copies
    cursor = tuple(ras.voxel_to_world((83, 121, 70)))
    from_ras, viewer = slice_image(ras, size, orientation=orientation, cursor=cursor,
                                   interpolation=interpolation)
    from_lps, _ = slice_image(lps, size, orientation=orientation, cursor=cursor, interpolation=interpolation)
    assert from_ras[..., 3].mean() > 0.85 and from_ras[..., 0].std() > 0.1  # the head fills it
    if interpolation == "nearest":
        np.testing.assert_array_equal(from_lps, from_ras)
    else:
        np.testing.assert_allclose(from_lps, from_ras, atol=TOLERANCE, rtol=0)
    if orientation == "axial":  # radiological: the patient's right (RAS +x) on the image's left
        assert viewer.pixel_to_world(0, 0)[0] > viewer.pixel_to_world(size[0] - 1, 0)[0]


# --- a tilted volume -------------------------------------------------------------------------------
def tilted_volume(degrees: float = 35.0) -> Volume:
    data = ndimage.gaussian_filter(np.random.default_rng(11).random((20, 28, 24)), 1.5).astype(np.float32)
    return Volume(data, spacing=(1.2, 0.9, 1.6), origin=(-10.0, 4.0, 7.0), direction=rotation_about_x(degrees))


def test_an_axial_slice_of_a_tilted_volume_samples_the_tilted_anatomy():
    volume = tilted_volume()
    size = (60, 50)
    image, viewer = slice_image(volume, size, orientation="axial", interpolation="linear")
    columns, rows = np.meshgrid(np.arange(size[0]), np.arange(size[1]))
    voxel = volume.world_to_voxel(viewer.pixel_to_world(columns, rows))
    data = volume.normalized(volume.data)
    expected = ndimage.map_coordinates(data, voxel[..., ::-1].transpose(2, 0, 1), order=1, mode="nearest")
    inside = np.all((voxel >= -0.5) & (voxel <= np.array(volume.dims) - 0.5), axis=-1)
    assert 0.3 < inside.mean() < 0.95  # the tilted box leaves corners of the image empty
    np.testing.assert_allclose(image[..., 0], np.where(inside, expected, 0.0), atol=TOLERANCE, rtol=0)
    np.testing.assert_array_equal(image[..., 3], inside.astype(np.float32))
    # the same voxels on an untilted grid give another picture: the direction is not ignored
    untilted = volume.with_overrides(direction=IDENTITY)
    other, _ = slice_image(untilted, size, orientation="axial", interpolation="linear")
    assert np.abs(other[..., 0] - image[..., 0]).max() > 0.1


def test_cursor_framing_and_outline_follow_the_oriented_box():
    volume = tilted_volume()
    _, viewer = slice_image(volume, (64, 48), orientation="coronal")
    plane = viewer.last_plane
    centre = volume.voxel_to_world((np.array(volume.dims) - 1) / 2.0)
    np.testing.assert_allclose(plane.centre, centre, atol=1e-9)  # the default cursor: the box centre
    uv = plane.uv_of(GridBox.of(volume).corners())  # the cells' box, oriented
    spans = uv.max(axis=0) - uv.min(axis=0)
    assert np.isclose(spans.max(), 1.0) and spans.min() <= 1.0 + 1e-12  # fits, aspect kept
    np.testing.assert_allclose((uv.max(axis=0) + uv.min(axis=0)) / 2.0, 0.5, atol=1e-12)  # centred
    outline = plane.outline()
    assert 3 <= len(outline) <= 6
    np.testing.assert_allclose((outline - centre) @ np.asarray(plane.normal), 0.0, atol=1e-9)
    index = volume.world_to_voxel(outline)
    high = np.array(volume.dims) - 0.5
    assert np.all((index >= -0.5 - 1e-9) & (index <= high + 1e-9))  # inside the oriented cells' box
    on_face = np.isclose(index, -0.5) | np.isclose(index, high)
    assert on_face.any(axis=1).all()  # and on its surface


def test_the_wheel_steps_one_voxel_along_the_normal_in_index_units():
    volume = tilted_volume()
    normal = np.array([0.0, 0.0, -1.0])
    step = page_step(normal, volume.spacing, volume.direction)
    moved = volume.world_to_voxel(step * normal) - volume.world_to_voxel(np.zeros(3))
    assert np.linalg.norm(moved) == pytest.approx(1.0)
    assert page_step(normal, volume.spacing, np.diag([-1.0, -1.0, 1.0])) == pytest.approx(1.6)
