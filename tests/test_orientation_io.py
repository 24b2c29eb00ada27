"""Orientation at the readers and writers (issue 28): every reader puts each voxel where the file
says, in RAS (LPS files are converted), sheared grids are refused by name, and a round trip
through vgraph's writers lands on the same voxels in nibabel, pynrrd, ITK's MetaImage form and
VTK's. Every file is made here with nibabel, pydicom or pynrrd, or written as the text ITK and
VTK write; nothing is downloaded."""

import subprocess
import sys

import nibabel as nib
import nrrd
import numpy as np
import pytest

from vgraph.io.convert import StoreOrientationWarning, convert
from vgraph.bricks.volume import BrickedVolume
from vgraph.errors import VolumeFileError
from vgraph.io import read_volume, write_volume
from vgraph.volume import Volume

LPS = np.diag([-1.0, -1.0, 1.0])
SHAPE_XYZ = (6, 5, 4)


def rotation_about_x(degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    return np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])


def labelled_xyz() -> np.ndarray:
    """An [x, y, z] array (nibabel's order) whose every voxel holds its own value."""
    return np.arange(np.prod(SHAPE_XYZ), dtype=np.int16).reshape(SHAPE_XYZ)


def world_of_each_value(volume: Volume) -> np.ndarray:
    """The world point (RAS) of every voxel, in the order of the voxels' values."""
    k, j, i = np.indices(volume.data.shape)
    world = volume.voxel_to_world(np.stack([i, j, k], axis=-1).reshape(-1, 3))
    return world[np.argsort(volume.data.reshape(-1), kind="stable")]


def save_nifti(path, data_xyz, affine):
    nib.save(nib.Nifti1Image(data_xyz, affine), str(path))
    return path


# --- NIfTI ----------------------------------------------------------------------------------------
def test_lps_and_ras_copies_of_one_nifti_put_every_voxel_value_at_the_same_world_point(tmp_path):
    affine = np.array([[2.0, 0, 0, -110], [0, 2.5, 0, -119], [0, 0, 3, -18], [0, 0, 0, 1]])
    ras = nib.Nifti1Image(labelled_xyz(), affine)
    # nibabel's own reorientation: the voxels stored right-to-left, anterior-to-posterior
    lps = ras.as_reoriented(nib.orientations.axcodes2ornt(("L", "P", "S")))
    assert nib.aff2axcodes(lps.affine) == ("L", "P", "S")
    nib.save(ras, str(tmp_path / "ras.nii.gz"))
    nib.save(lps, str(tmp_path / "lps.nii.gz"))
    from_ras, from_lps = read_volume(tmp_path / "ras.nii.gz"), read_volume(tmp_path / "lps.nii.gz")
    assert from_ras.direction == ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    assert from_lps.direction == ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0))
    np.testing.assert_allclose(from_lps.affine, lps.affine, atol=1e-6)
    np.testing.assert_allclose(world_of_each_value(from_lps), world_of_each_value(from_ras), atol=1e-6)
    # the value of voxel (0, 0, 0) of the RAS copy sits at the affine's translation in both
    np.testing.assert_allclose(world_of_each_value(from_lps)[0], (-110, -119, -18), atol=1e-6)


def test_a_tilted_nifti_keeps_its_tilt(tmp_path):
    """Like dipy's aniso_vox: anisotropic voxels turned about 35 degrees about x."""
    affine = np.eye(4)
    affine[:3, :3] = rotation_about_x(35.0) @ np.diag([1.0, 2.0, 3.0])
    affine[:3, 3] = (-20.0, 14.5, 7.25)
    volume = read_volume(save_nifti(tmp_path / "tilted.nii", labelled_xyz(), affine))
    np.testing.assert_allclose(volume.spacing, (1.0, 2.0, 3.0), rtol=1e-6)
    np.testing.assert_allclose(volume.affine, affine, atol=1e-6)
    assert not volume.is_axis_aligned


def sheared_nifti(tmp_path):
    affine = np.array([[1.0, 0.4, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    return save_nifti(tmp_path / "sheared.nii.gz", labelled_xyz(), affine)


def test_a_sheared_nifti_is_refused_naming_the_file_and_the_direction(tmp_path):
    path = sheared_nifti(tmp_path)
    with pytest.raises(VolumeFileError) as caught:
        read_volume(path)
    error = caught.value
    assert error.file == str(path) and "sform" in error.field
    assert "direction cosines" in error.reason and "sheared" in error.reason
    assert "68.2" in error.reason  # the angle the index axes i and j meet at, in degrees


def test_a_sheared_nifti_ends_the_command_line_with_exit_2_and_one_line(tmp_path):
    path = sheared_nifti(tmp_path)
    done = subprocess.run([sys.executable, "-m", "vgraph", "run", str(path), "-o", str(tmp_path / "o.png")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith("vgraph: error:")]
    assert len(errors) == 1 and str(path) in errors[0] and "direction" in errors[0]
    assert "Traceback" not in done.stderr and not (tmp_path / "o.png").exists()


def test_a_4d_nifti_keeps_its_affine_and_time_points(tmp_path):
    affine = np.diag([-1.5, 1.5, 2.0, 1.0])
    series = np.stack([labelled_xyz() + 100 * t for t in range(3)], axis=-1)
    path = save_nifti(tmp_path / "series.nii.gz", series, affine)
    volume = read_volume(path, time_step=2)
    assert volume.time_steps == 3 and volume.data[0, 0, 0] == 200
    np.testing.assert_allclose(volume.affine, affine, atol=1e-6)


# --- DICOM ----------------------------------------------------------------------------------------
def dicom_slice(path, position, orientation=(1, 0, 0, 0, 1, 0), index=0, pixel_spacing=(0.5, 0.75),
                thickness="2.5"):
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"  # CT Image Storage
    meta.MediaStorageSOPInstanceUID = f"1.2.3.{index}"
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = Dataset()
    ds.file_meta, ds.SeriesInstanceUID, ds.Rows, ds.Columns = meta, "1.2.3", 3, 4
    ds.BitsAllocated, ds.BitsStored, ds.PixelRepresentation, ds.SamplesPerPixel = 16, 16, 0, 1
    ds.PhotometricInterpretation, ds.PixelSpacing = "MONOCHROME2", list(pixel_spacing)
    ds.ImageOrientationPatient, ds.ImagePositionPatient = list(orientation), list(position)
    ds.SliceThickness, ds.InstanceNumber = thickness, index + 1
    ds.PixelData = (np.arange(12, dtype=np.uint16) + 100 * index).reshape(3, 4).tobytes()
    ds.save_as(path, enforce_file_format=True)
    return path


def dicom_world_lps(position, orientation, pixel_spacing, column, row) -> np.ndarray:
    """DICOM PS3.3 C.7.6.2.1.1: the patient (LPS) position of the pixel in ``column``, ``row``."""
    row_cosines, column_cosines = np.array(orientation[:3]), np.array(orientation[3:])
    return (np.asarray(position, dtype=float) + row_cosines * pixel_spacing[1] * column
            + column_cosines * pixel_spacing[0] * row)


def test_a_single_axial_dicom_slice_is_read_in_ras_with_the_normal_as_its_third_axis(tmp_path):
    volume = read_volume(dicom_slice(tmp_path / "ct.dcm", (-120.5, -80.25, 33.0)))
    assert volume.direction == ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0))
    assert volume.origin == (120.5, 80.25, 33.0)
    assert volume.spacing == (0.75, 0.5, 2.5)  # column spacing, row spacing, SliceThickness


def test_an_axial_dicom_series_is_read_in_ras(tmp_path):
    for k, z in enumerate((40.0, 37.5, 42.5)):  # files out of order
        dicom_slice(tmp_path / f"{k}.dcm", (-120.5, -80.25, z), index=k)
    volume = read_volume(tmp_path)
    assert volume.direction == ((-1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0))
    assert volume.origin == (120.5, 80.25, 37.5)
    np.testing.assert_allclose(volume.spacing, (0.75, 0.5, 2.5))
    assert [int(volume.data[k, 0, 0]) for k in range(3)] == [100, 0, 200]  # sorted along +z


def test_an_oblique_dicom_series_puts_every_pixel_where_dicom_says(tmp_path):
    """A sagittal-oblique series: each pixel's RAS position is the DICOM formula's LPS one with
    x and y negated."""
    turn = rotation_about_x(20.0)
    row_cosines, column_cosines = turn @ (0.0, 1.0, 0.0), turn @ (0.0, 0.0, -1.0)
    orientation = (*row_cosines, *column_cosines)
    normal = np.cross(row_cosines, column_cosines)
    positions = [np.array((12.0, -30.0, 7.0)) + 1.25 * k * normal for k in range(3)]
    for k, position in enumerate(positions):
        dicom_slice(tmp_path / f"{k}.dcm", position, orientation, index=k)
    volume = read_volume(tmp_path)
    for column, row, k in ((0, 0, 0), (3, 0, 0), (0, 2, 1), (3, 2, 2)):
        expected = LPS @ dicom_world_lps(positions[k], orientation, (0.5, 0.75), column, row)
        np.testing.assert_allclose(volume.voxel_to_world((column, row, k)), expected, atol=1e-6)
        assert volume.data[k, row, column] == 100 * k + 4 * row + column


def test_a_gantry_tilted_dicom_series_is_refused_naming_the_positions(tmp_path):
    for k in range(3):  # each slice shifted along y as it goes along z: a sheared grid
        dicom_slice(tmp_path / f"{k}.dcm", (0.0, 0.5 * k, 2.0 * k), index=k)
    with pytest.raises(VolumeFileError, match="gantry tilt") as caught:
        read_volume(tmp_path)
    assert caught.value.field == "ImagePositionPatient" and "sheared" in caught.value.reason


# --- NRRD -----------------------------------------------------------------------------------------
def nrrd_file(path, header_extra: dict):
    header = {"space directions": np.array([[0.0, 1.5, 0.0], [-2.0, 0.0, 0.0], [0.0, 0.0, 2.5]]),
              "space origin": np.array([10.0, -20.0, 30.0]), **header_extra}
    nrrd.write(str(path), labelled_xyz(), header)  # pynrrd's default index order: x fastest
    return path, header


@pytest.mark.parametrize("space, to_ras", [("left-posterior-superior", LPS), ("LPS", LPS),
                                           ("scanner-xyz", LPS), ("right-anterior-superior", np.eye(3)),
                                           ("left-anterior-superior", np.diag([-1.0, 1.0, 1.0]))])
def test_nrrd_space_directions_are_read_in_ras(tmp_path, space, to_ras):
    path, header = nrrd_file(tmp_path / "v.nrrd", {"space": space})
    volume = read_volume(path)
    expected = np.eye(4)
    expected[:3, :3] = to_ras @ header["space directions"].T  # pynrrd: one row per index axis
    expected[:3, 3] = to_ras @ header["space origin"]
    np.testing.assert_allclose(volume.affine, expected, atol=1e-12)
    np.testing.assert_allclose(volume.spacing, (1.5, 2.0, 2.5))


def test_an_unknown_nrrd_space_is_refused_by_name(tmp_path):
    path, _ = nrrd_file(tmp_path / "v.nrrd", {"space": "left-anterior-inferior"})
    with pytest.raises(VolumeFileError, match="unknown space") as caught:
        read_volume(path)
    assert caught.value.field == "space"


def test_a_nrrd_without_space_information_keeps_its_axes(tmp_path):
    nrrd.write(str(tmp_path / "v.nrrd"), labelled_xyz(), {"spacings": [0.5, 0.25, 2.0]})
    volume = read_volume(tmp_path / "v.nrrd")
    assert volume.is_axis_aligned and volume.spacing == (0.5, 0.25, 2.0) and volume.origin == (0, 0, 0)


# --- MetaImage ------------------------------------------------------------------------------------
# The header SimpleITK 2.5 (ITK 5.4) wrote for an image whose RAS affine is ITK_AFFINE_RAS below:
# TransformMatrix lists each index axis's direction (LPS) in turn, Offset is in LPS.
ITK_HEADER = """ObjectType = Image
NDims = 3
BinaryData = True
BinaryDataByteOrderMSB = False
CompressedData = False
TransformMatrix = -0 0 1 -0.81915204195062907 -0.57357643969057426 0 0.57357644902558169 -0.81915203541418635 0
Offset = 110 119 -18
CenterOfRotation = 0 0 0
AnatomicalOrientation = ILP
ElementSpacing = 1.5 2 3
DimSize = 6 5 4
ElementType = MET_SHORT
ElementDataFile = LOCAL
"""
ITK_AFFINE_RAS = np.array([[0.0, 1.6383040885779836, -1.7207293090531389, -110.0],
                           [0.0, 1.147152872702092, 2.457456132866976, -119.0],
                           [1.5, 0.0, 0.0, -18.0], [0.0, 0.0, 0.0, 1.0]])


def test_a_metaimage_written_by_itk_is_read_onto_its_affine(tmp_path):
    path = tmp_path / "itk.mha"
    path.write_bytes(ITK_HEADER.encode() + labelled_xyz().T.astype("<i2").tobytes())
    volume = read_volume(path)
    np.testing.assert_allclose(volume.affine, ITK_AFFINE_RAS, atol=1e-6)
    np.testing.assert_array_equal(volume.data, labelled_xyz().T)


def test_a_metaimage_that_declares_no_frame_keeps_its_coordinates(tmp_path):
    header = ("NDims = 3\nDimSize = 6 5 4\nElementSpacing = 1 2 3\nOffset = 4 5 6\n"
              "ElementType = MET_SHORT\nElementDataFile = LOCAL\n")
    path = tmp_path / "plain.mha"
    path.write_bytes(header.encode() + labelled_xyz().T.astype("<i2").tobytes())
    volume = read_volume(path)
    assert volume.is_axis_aligned and volume.origin == (4.0, 5.0, 6.0)


def test_a_sheared_metaimage_transform_is_refused_by_name(tmp_path):
    header = ITK_HEADER.replace("TransformMatrix = -0 0 1 -0.81915204195062907",
                                "TransformMatrix = -0 0.3 1 -0.81915204195062907")
    path = tmp_path / "sheared.mha"
    path.write_bytes(header.encode() + labelled_xyz().T.astype("<i2").tobytes())
    with pytest.raises(VolumeFileError, match="direction cosines") as caught:
        read_volume(path)
    assert caught.value.field == "TransformMatrix"


# --- VTI ------------------------------------------------------------------------------------------
def test_a_vti_direction_is_read_row_by_row(tmp_path):
    """The ImageData element VTK 9.7's vtkXMLImageDataWriter wrote for an image of the affine
    ITK_AFFINE_RAS: Direction is the 3x3 matrix row by row, its columns the index axes; VTK's
    world is taken as it stands."""
    values = " ".join(map(str, range(60)))
    (tmp_path / "d.vti").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="ImageData" version="0.1" byte_order="LittleEndian">\n'
        '  <ImageData WholeExtent="0 4 0 3 0 2" Origin="-110 -119 -18" Spacing="1.5 2 3" Direction="0 '
        '0.8191520442889919 -0.5735764363510459 0 0.573576436351046 0.8191520442889919 1 0 0">\n'
        '    <Piece Extent="0 4 0 3 0 2"><PointData Scalars="values">'
        f'<DataArray type="Int16" Name="values" format="ascii">{values}</DataArray></PointData>'
        '</Piece>\n  </ImageData>\n</VTKFile>\n')
    volume = read_volume(tmp_path / "d.vti")
    np.testing.assert_allclose(volume.affine, ITK_AFFINE_RAS, atol=1e-6)


# --- writers: round trips -------------------------------------------------------------------------
def oriented_volume(direction) -> Volume:
    return Volume(labelled_xyz().T.copy(), spacing=(1.5, 2.0, 3.0), origin=(-110.0, -119.0, -18.0),
                  direction=tuple(map(tuple, direction)))


TURNS = {"tilted": rotation_about_x(35.0), "mirrored": rotation_about_x(35.0) @ np.diag([-1.0, 1.0, 1.0]),
         "lps": LPS}


@pytest.mark.parametrize("turn", list(TURNS))
@pytest.mark.parametrize("extension", [".nii.gz", ".nii", ".nrrd", ".mha", ".vti", ".npz"])
def test_every_writer_keeps_the_affine_for_vgraph(tmp_path, turn, extension):
    original = oriented_volume(TURNS[turn])
    back = read_volume(write_volume(original, tmp_path / f"v{extension}"))
    np.testing.assert_allclose(back.affine, original.affine, atol=1e-6)
    np.testing.assert_array_equal(back.data, original.data)


@pytest.mark.parametrize("turn", list(TURNS))
def test_written_nifti_and_nrrd_hold_the_affine_for_nibabel_and_pynrrd(tmp_path, turn):
    original = oriented_volume(TURNS[turn])
    image = nib.load(str(write_volume(original, tmp_path / "v.nii.gz")))
    assert int(image.header["sform_code"]) == 1 and int(image.header["qform_code"]) == 1
    np.testing.assert_allclose(image.header.get_sform(), original.affine, atol=1e-6)
    np.testing.assert_allclose(image.header.get_qform(), original.affine, atol=1e-6)
    np.testing.assert_array_equal(np.asarray(image.dataobj), labelled_xyz())
    _, header = nrrd.read(str(write_volume(original, tmp_path / "v.nrrd")))
    assert header["space"] == "right-anterior-superior"
    np.testing.assert_allclose(header["space directions"].T, original.affine[:3, :3], atol=1e-12)
    np.testing.assert_allclose(header["space origin"], original.origin)


def test_a_written_metaimage_says_what_itk_itself_writes(tmp_path):
    """The header of ITK_HEADER's image written by vgraph: ITK's TransformMatrix, Offset and
    AnatomicalOrientation (the values SimpleITK wrote, to their printed digits)."""
    spacing = np.linalg.norm(ITK_AFFINE_RAS[:3, :3], axis=0)
    volume = Volume(labelled_xyz().T.copy(), spacing=tuple(spacing), origin=tuple(ITK_AFFINE_RAS[:3, 3]),
                    direction=tuple(map(tuple, ITK_AFFINE_RAS[:3, :3] / spacing)))
    written = write_volume(volume, tmp_path / "v.mha").read_bytes()
    header = dict(line.split(" = ") for line in written.split(b"ElementDataFile")[0].decode().splitlines())
    itk = dict(line.split(" = ") for line in ITK_HEADER.splitlines())
    for key in ("TransformMatrix", "Offset", "ElementSpacing"):
        np.testing.assert_allclose(np.array(header[key].split(), float), np.array(itk[key].split(), float),
                                   atol=1e-7)
    assert header["AnatomicalOrientation"] == itk["AnatomicalOrientation"] == "ILP"


def test_run_data_out_nii_gz_lands_on_the_same_voxels_in_nibabel(tmp_path):
    """The defect's example: an LPS-stored head written back by ``vgraph run --data``: before, the
    affine became diagonal and the far corner moved from (-110, -119, -18) to elsewhere."""
    affine = np.array([[-2.0, 0, 0, -100], [0, -2.5, 0, -109], [0, 0, 3, -27], [0, 0, 0, 1]])
    source = save_nifti(tmp_path / "head_lps.nii.gz", labelled_xyz(), affine)
    corner = np.array([*(np.array(SHAPE_XYZ) - 1), 1.0])
    assert np.allclose((affine @ corner)[:3], (-110, -119, -18))
    out = tmp_path / "out.nii.gz"
    done = subprocess.run([sys.executable, "-m", "vgraph", "run", str(source), "--port", "source.volume",
                           "--data", str(out)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    written = nib.load(str(out))
    np.testing.assert_allclose(written.affine, affine, atol=1e-6)
    np.testing.assert_allclose((written.affine @ corner)[:3], (-110, -119, -18), atol=1e-6)
    np.testing.assert_array_equal(np.asarray(written.dataobj), labelled_xyz())


def test_run_on_a_data_file_writes_the_volume_read_and_the_picture_in_one_go(tmp_path):
    """Without --port, a volume-only format (.nii.gz) writes the volume read, -o the picture, as
    the issue asks: `vgraph run VOL --data out.nii.gz` then nibabel gives the original affine."""
    affine = np.array([[-2.0, 0, 0, -100], [0, -2.5, 0, -109], [0, 0, 3, -27], [0, 0, 0, 1]])
    source = save_nifti(tmp_path / "head_lps.nii.gz", labelled_xyz(), affine)
    out, picture, image_data = tmp_path / "out.nii.gz", tmp_path / "out.png", tmp_path / "image.npz"
    done = subprocess.run([sys.executable, "-m", "vgraph", "run", str(source), "--data", str(out),
                           "-o", str(picture), "--data", str(image_data)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    np.testing.assert_allclose(nib.load(str(out)).affine, affine, atol=1e-6)
    assert picture.stat().st_size > 0 and np.load(image_data)["image"].shape[-1] == 4
    refused = subprocess.run([sys.executable, "-m", "vgraph", "run", str(source), "--data", str(out),
                              "--tiles", "2x2"], capture_output=True, text=True, timeout=300)
    assert refused.returncode == 2 and "writes the volume read" in refused.stderr
    assert "Traceback" not in refused.stderr


# --- OME-Zarr stores ------------------------------------------------------------------------------
@pytest.mark.parametrize("turn", ["tilted", "mirrored"])
def test_convert_keeps_the_direction_in_the_store(tmp_path, turn):
    original = oriented_volume(TURNS[turn])
    source = write_volume(original, tmp_path / "v.nii")
    with pytest.warns(StoreOrientationWarning, match="other tools show the store unrotated"):
        convert(source, tmp_path / "v.zarr", brick=4, progress=False)
    store = BrickedVolume.open(tmp_path / "v.zarr")
    assert np.linalg.det(np.asarray(store.direction)) > 0  # a rotation, mirrored or not before
    if turn == "tilted":
        np.testing.assert_allclose(store.affine, original.affine, atol=1e-6)
    np.testing.assert_allclose(world_of_each_value(store), world_of_each_value(original), atol=1e-5)


def test_convert_of_an_unturned_volume_writes_no_direction(tmp_path):
    import zarr
    source = write_volume(oriented_volume(np.eye(3)), tmp_path / "v.nii")
    convert(source, tmp_path / "v.zarr", brick=4, progress=False)
    assert "direction" not in zarr.open_group(str(tmp_path / "v.zarr"), mode="r").attrs["vgraph"]
    assert BrickedVolume.open(tmp_path / "v.zarr").is_axis_aligned
