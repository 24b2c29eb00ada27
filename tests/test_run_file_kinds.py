"""`vgraph run FILE` and `vgraph gui FILE` choose the network by what the file holds (issue 28):
a single slice (DICOM, a 1-slice NIfTI) shows as the image it is in its own plane, windowed from
the data, not as a black box seen edge-on; a PNG as it is; labels (declared by the file, or an
integer volume with few, mostly consecutive values) through the LabelRayCaster with a colour per
label; --labels / --intensity decide instead; the real scans of the shared data stay intensities."""

import numpy as np
import nibabel as nib
import nrrd
import pydicom
import pytest
from PIL import Image as PILImage

import vgraph
from vgraph.cli import main
from vgraph.file_kind import file_kind, slice_orientation
from vgraph.file_labels import (MAX_GUESSED_LABELS, categorical_color, distinct_label_table,
                                guessed_labels)
from vgraph.io import read_volume
from vgraph.io.vti import write_vti
from vgraph.volume import Volume

from helpers.dicom import write_ct_slice
from helpers.paths import DATA, REPO

REAL_VOLUMES = ["ct_bonsai/bonsai.nii.gz", "ct_engine/engine.nii.gz", "ct_head_headsq/quarter.nhdr",
                "cta_stent/stent.npz", "dicom_mr_scout", "mri_head_t1/MR.nii.gz",
                "mri_head_tiny/HeadMRVolume.mhd", "sim_hydrogen/hydrogen.vti", "sim_neghip/neghip.slc",
                "sim_neghip/neghip_66x66x66_uint8.dat", "sim_hydrogen/hydrogen_64x64x64_float32.nhdr"]


def png(path) -> np.ndarray:
    return np.asarray(PILImage.open(path)).astype(np.float64) / 255.0


def types(network) -> set:
    return {processor.type_name for processor in network.processors.values()}


def frog_like(shape=(12, 20, 58)) -> np.ndarray:
    """29 labels 0..28 (0 the background around them): label k fills the slab of x in
    [2k, 2k + 2) inside a margin, so that seen from the front each label is a band of its own."""
    z, y, x = np.indices(shape)
    labels = np.minimum(x // 2, 28).astype(np.uint8)
    inside = (z > 0) & (z < shape[0] - 1) & (y > 0) & (y < shape[1] - 1)
    return np.where(inside, labels, 0).astype(np.uint8)


# --- a single slice ----------------------------------------------------------------------------
@pytest.fixture
def ct_slice(tmp_path):
    pixels = np.random.default_rng(5).integers(-1000, 3000, size=(24, 32)).astype(np.int16)
    pixels[2:5, 3:9] = 3000  # a mark near the top left: a flip of either axis moves it
    write_ct_slice(tmp_path / "ct.dcm", pixels)
    return tmp_path / "ct.dcm"


def windowed(values: np.ndarray, volume: Volume) -> np.ndarray:
    """The grey the robust window gives (VolumeSource.window = robust: percentiles 0.5, 99.5)."""
    low, high = volume.percentiles([0.5, 99.5])
    return np.clip((values - low) / (high - low), 0.0, 1.0)


def test_a_single_dicom_slice_renders_as_pydicoms_array_in_the_robust_window(ct_slice, tmp_path, capsys):
    ds = pydicom.dcmread(ct_slice)
    hounsfield = ds.pixel_array * float(ds.RescaleSlope) + float(ds.RescaleIntercept)
    expected = windowed(hounsfield, read_volume(ct_slice))
    out = tmp_path / "ct.png"
    assert main(["run", str(ct_slice), "-o", str(out), "--size", f"{ds.Columns}x{ds.Rows}"]) == 0
    pixels = png(out)
    # pixel centres on voxel centres: each pixel is its voxel's grey (row 0 at the top, column 0 at
    # the left: pydicom's display, radiological), within the PNG's 8 bits
    np.testing.assert_allclose(pixels[..., 0], expected, atol=0.5 / 255 + 1e-6)
    assert np.all(pixels[..., 3] == 1.0)
    assert "ct.dcm is a single slice (32 x 24 x 1 voxels): shown as an image in its axial plane" \
           in capsys.readouterr().err


def test_a_single_slice_at_the_default_size_keeps_its_aspect_and_structure(ct_slice, tmp_path):
    out = tmp_path / "ct.png"
    assert main(["run", str(ct_slice), "-o", str(out)]) == 0
    pixels = png(out)[..., 0]
    assert pixels.shape == (384, 512)  # 32 x 24 voxels magnified 16 times
    ds = pydicom.dcmread(ct_slice)
    expected = windowed(ds.pixel_array - 1024.0, read_volume(ct_slice))
    # the voxels' greys at the pixel centres that fall on them (16k + 7.5: voxel k's centre)
    centres = pixels[7::16, 7::16] * 0.5 + pixels[8::16, 8::16] * 0.5
    assert np.corrcoef(centres.ravel(), expected.ravel())[0, 1] > 0.99
    assert pixels.std() > 0.1  # not black, not flat


def test_a_one_slice_nifti_shows_in_the_plane_that_holds_it(tmp_path):
    """A coronal slice (y one voxel thick) in RAS: coronal view, patient's right on the left."""
    values = np.random.default_rng(2).random((20, 1, 16)).astype(np.float32)  # (x, y, z)
    values[2:5, 0, 12:15] = 4.0  # towards +x (the patient's left) and +z (up)
    nib.save(nib.Nifti1Image(values, np.eye(4)), tmp_path / "coronal.nii.gz")
    kind = file_kind(tmp_path / "coronal.nii.gz")
    assert (kind.kind, kind.orientation) == ("slice", "coronal")
    network = vgraph.load(tmp_path / "coronal.nii.gz")
    assert types(network) == {"VolumeSource", "SliceViewer", "Canvas"}
    image = network.evaluate("canvas", size=(20, 16))[..., 0]
    # coronal, radiological: image right = -x, image up = +z
    expected = windowed(values[::-1, 0, ::-1].T, network.output("source.volume"))
    np.testing.assert_allclose(image, expected, atol=2e-5)


def test_a_slice_of_labels_shows_each_voxel_in_its_labels_colour(tmp_path, capsys):
    labels = (np.indices((12, 10))[0] // 3 + 3 * (np.indices((12, 10))[1] >= 5)).astype(np.uint8)  # (x, y)
    nib.save(nib.Nifti1Image(labels[:, :, None], np.eye(4)), tmp_path / "labels.nii")  # 0..6 blocks
    out = tmp_path / "labels.png"
    assert main(["run", str(tmp_path / "labels.nii"), "-o", str(out), "--size", "12x10"]) == 0
    assert "labels.nii is a single slice (12 x 10 x 1 voxels) of 7 labels (0..6): shown as an image " \
           "in its axial plane, a colour per label" in capsys.readouterr().err
    colours = np.vstack([[0.0, 0.0, 0.0], distinct_label_table(range(7)).colors(np.arange(1, 7))[:, :3]])
    shown = labels[::-1, ::-1].T  # axial, radiological: image right = -x, image up = +y
    np.testing.assert_array_equal(np.asarray(PILImage.open(out))[..., :3], np.rint(colours[shown] * 255))


def test_an_oblique_slice_is_shown_in_its_own_plane():
    tilt = np.radians(20.0)
    direction = np.array([[1, 0, 0], [0, np.cos(tilt), -np.sin(tilt)], [0, np.sin(tilt), np.cos(tilt)]])
    volume = Volume(np.zeros((1, 8, 8), np.float32), direction=direction)
    orientation, normal = slice_orientation(volume)
    assert orientation == "custom"
    np.testing.assert_allclose(normal, -direction[:, 2])  # the side the axial view looks from


def test_a_picture_is_shown_as_it_is_at_its_size(tmp_path, capsys):
    rgb = np.random.default_rng(4).integers(0, 256, size=(30, 40, 3), dtype=np.uint8)
    PILImage.fromarray(rgb).save(tmp_path / "photo.png")
    out = tmp_path / "out.png"
    assert main(["run", str(tmp_path / "photo.png"), "-o", str(out)]) == 0
    pixels = np.asarray(PILImage.open(out))
    assert pixels.shape == (30, 40, 4)
    np.testing.assert_array_equal(pixels[..., :3], rgb)
    assert "photo.png is a picture: shown as it is" in capsys.readouterr().err


# --- labels ------------------------------------------------------------------------------------
def vti_with_array_name(path, data: np.ndarray, name: str) -> None:
    write_vti(Volume(data), path)
    blob = path.read_bytes()
    path.write_bytes(blob.replace(b'"values"', f'"{name}"'.encode(), 2))  # in the XML head only


@pytest.fixture
def label_files(tmp_path):
    frog = frog_like()
    vti_with_array_name(tmp_path / "frog_tissues.vti", frog, "tissue labels")
    many = (np.indices((10, 10, 10)).sum(axis=0) * 4).astype(np.int16)  # 0..108 in steps of 4
    image = nib.Nifti1Image(many.T, np.eye(4))
    image.header.set_intent("label")
    nib.save(image, tmp_path / "atlas.nii.gz")
    np.save(tmp_path / "frog.npy", frog)
    return tmp_path


def test_declared_and_guessed_labels_render_through_the_label_ray_caster(label_files):
    for name, says in [("frog_tissues.vti", True), ("atlas.nii.gz", True), ("frog.npy", False)]:
        assert read_volume(label_files / name).holds_labels is says
        network = vgraph.load(label_files / name)
        assert "LabelRayCaster" in types(network) and "RayCaster" not in types(network), name
    # 28 values spaced by 4 are not consecutive: only the intent makes the atlas labels
    assert not guessed_labels(read_volume(label_files / "atlas.nii.gz")).found


def test_every_label_has_a_colour_of_its_own_in_the_picture(label_files, tmp_path, capsys):
    out = tmp_path / "frog.png"
    assert main(["run", str(label_files / "frog.npy"), "-o", str(out), "--size", "240x120",
                 "--set", "labels.shading=none", "--set", "labels.compositing=first_hit"]) == 0
    assert ("frog.npy holds 29 labels (integer values 0..28): rendered as labels by the "
            "LabelRayCaster; --intensity renders intensities") in capsys.readouterr().err
    colours = {tuple(c) for c in np.asarray(PILImage.open(out))[..., :3].reshape(-1, 3)} - {(0, 0, 0)}
    table = distinct_label_table(range(29)).colors(np.arange(1, 29))[:, :3]
    expected = {tuple(np.rint(c * 255).astype(int)) for c in table}
    assert len(expected) == 28 and colours == expected  # each label seen, in its own colour


def test_the_label_table_gives_distinct_colours_past_the_palette():
    table = distinct_label_table(range(65))
    colours = table.colors(np.arange(1, 65))[:, :3]
    assert len({tuple(c) for c in colours}) == 64
    assert tuple(colours[0]) == pytest.approx(categorical_color(0))
    few = distinct_label_table([0, 1, 2, 5])  # the palette's colours already differ: default table
    assert few == few.default()


def test_the_guess_takes_label_maps_and_leaves_intensities(tmp_path):
    def guess(values, dtype=np.uint8):
        return guessed_labels(Volume(np.asarray(values, dtype=dtype).reshape(1, 1, -1))).found
    assert guess([0, 1, 1, 0])                                          # a 0/1 mask
    assert guess([0, 2, 4, 5, 7, 8, 10, 11, 12, 13, 14, 15, 16, 17, 18, 24, 26, 28, 30, 31, 41, 42],
                 np.int16)                                              # FreeSurfer aseg's numbering
    assert not guess(np.rint(np.arange(33) * 62.5), np.int16)           # a quantised CTA (stent.npz)
    assert not guess([0, 255])                                          # a 0/255 mask: intensities
    assert not guess(np.arange(MAX_GUESSED_LABELS + 1), np.uint16)      # too many values
    assert not guess([0.0, 1.0, 2.0], np.float32)                       # floats are measurements


@pytest.mark.skipif(not DATA.is_dir(), reason="needs the shared data sets")
@pytest.mark.parametrize("name", REAL_VOLUMES)
def test_no_real_scan_is_taken_for_labels(name):
    kind = file_kind(DATA / name)
    assert kind.kind == "volume" and kind.labels is None, kind.sentence
    assert "holds intensities" in kind.sentence
    assert kind.ordinary == (name != "cta_stent/stent.npz")  # 33 values: said why not labels


@pytest.mark.skipif(not DATA.is_dir(), reason="needs the shared data sets")
def test_the_line_is_said_where_there_is_something_to_explain(tmp_path, capsys):
    assert main(["run", str(DATA / "mri_head_tiny" / "HeadMRVolume.mhd"), "-o", str(tmp_path / "h.png"),
                 "--size", "32x32"]) == 0
    assert "HeadMRVolume" not in capsys.readouterr().err  # intensities, rendered as ever
    assert main(["run", str(DATA / "cta_stent" / "stent.npz"), "-o", str(tmp_path / "s.png"),
                 "--size", "32x32"]) == 0
    assert ("vgraph: stent.npz holds intensities (int16, 33 distinct values spaced apart over 0..2000, "
            "0% next to another): shaded volume rendering (RayCaster, auto transfer function); "
            "--labels renders labels") in capsys.readouterr().err


def test_the_shipped_label_volume_is_labels():
    assert file_kind(REPO / "networks" / "data" / "engine_labels.nrrd").kind == "labels"


def test_header_declarations_of_labels(tmp_path):
    data = np.arange(300, dtype=np.uint16).reshape(3, 10, 10)  # 300 values: never a guess
    nrrd.write(str(tmp_path / "seg.nrrd"), data.T, {"Segment0_ID": "Segment_1", "Segment0_LabelValue": "1"})
    nrrd.write(str(tmp_path / "plain.nrrd"), data.T)
    nib.save(nib.Nifti1Image(data.T, np.eye(4)), tmp_path / "plain.nii")
    vti_with_array_name(tmp_path / "density.vti", data, "density")
    vti_with_array_name(tmp_path / "seg.vti", data, "SegmentationLabels")
    declared = {name: read_volume(tmp_path / name).holds_labels
                for name in ["seg.nrrd", "plain.nrrd", "plain.nii", "density.vti", "seg.vti"]}
    assert declared == {"seg.nrrd": True, "plain.nrrd": False, "plain.nii": False,
                        "density.vti": False, "seg.vti": True}


# --- --labels / --intensity -----------------------------------------------------------------------
def test_labels_and_intensity_flags_override_the_choice(label_files, tmp_path, capsys):
    intensity = vgraph.load(label_files / "frog.npy", render_as="intensity")
    assert "RayCaster" in types(intensity) and "LabelRayCaster" not in types(intensity)
    assert main(["run", str(label_files / "frog.npy"), "--intensity", "-o", str(tmp_path / "i.png"),
                 "--size", "32x32"]) == 0
    assert "frog.npy: intensities, as asked: shaded volume rendering" in capsys.readouterr().err
    head = DATA / "mri_head_tiny" / "HeadMRVolume.mhd"
    if head.exists():  # uint8 with 255 values, forced to labels
        assert "LabelRayCaster" in types(vgraph.load(head, render_as="labels"))


def test_flags_that_cannot_apply_are_refused_by_name(label_files, tmp_path, capsys):
    fractional = tmp_path / "density.npy"
    np.save(fractional, np.linspace(0, 1, 64, dtype=np.float32).reshape(4, 4, 4))
    cases = [
        (["run", str(fractional), "--labels", "-o", str(tmp_path / "x.png")],
         "--labels: density.npy holds float32 values that are not all whole numbers"),
        (["run", str(REPO / "networks" / "raycast_sphere.json"), "--labels", "-o", str(tmp_path / "x.png")],
         "--labels (render_as) applies to a data file, not to a network"),
        (["run", str(REPO / "networks" / "data" / "color_wheel.png"), "--intensity", "-o", str(tmp_path / "x.png")],
         "--intensity: color_wheel.png is a picture"),
        (["gui", str(REPO / "networks" / "raycast_sphere.json"), "--labels"],
         "--labels applies to a data file to open"),
    ]
    for argv, message in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, err
    with pytest.raises(SystemExit) as both:
        main(["run", str(label_files / "frog.npy"), "--labels", "--intensity"])
    assert both.value.code == 2
    assert "not allowed with argument" in capsys.readouterr().err


# --- the GUI opens a data file with the same builder ------------------------------------------
def test_the_gui_opens_a_single_slice_as_a_slice_viewer(window, ct_slice, label_files):
    window.workspace.open(ct_slice)
    assert "SliceViewer" in types(window.workspace.network)
    assert window.workspace.path is None  # untitled: saving never writes over the data file
    window.workspace.open(label_files / "frog.npy", render_as="intensity")
    assert "RayCaster" in types(window.workspace.network)
