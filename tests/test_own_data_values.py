"""Your own data, first try (issue #11): a scan's value range is its own min..max (a uint16 file
with 12-bit content used to render black), a robust window clips outlier voxels, 4D files give
one time point at a time, and a volume one voxel thick says why it looks flat. Checked as a user
meets them: through VolumeSource in a network, with real scans from shared/data where they
apply and synthetic files written here (nothing is downloaded)."""

import json
import shutil
import warnings

import nibabel as nib
import nrrd
import numpy as np
import pytest

from vgraph import Network, ProcessorError, VGraphWarning
from vgraph.camera import Camera
from vgraph.cli import main
from vgraph.gl.raycasting.components import TransferFunctionLut

TWELVE_BIT_MAX = 1500
OUTLIER = 30393


def ball(n=24) -> np.ndarray:
    """A smooth ball of 12-bit content (0 .. 1500) stored as uint16, [z, y, x]."""
    z, y, x = np.mgrid[0:n, 0:n, 0:n]
    radius = np.sqrt((x - n / 2 + 0.5) ** 2 + (y - n / 2 + 0.5) ** 2 + (z - n / 2 + 0.5) ** 2)
    return np.rint(np.clip(1.0 - radius / (n / 2), 0.0, 1.0) * TWELVE_BIT_MAX).astype(np.uint16)


def write_nrrd(folder, data, name="scan.nrrd"):
    path = folder / name
    nrrd.write(str(path), data, {"encoding": "gzip"}, index_order="C")
    return path


@pytest.fixture
def twelve_bit(tmp_path):
    """The acceptance case: 12-bit content with one outlier voxel (a metal artefact)."""
    data = ball()
    data[0, 0, 0] = OUTLIER
    return write_nrrd(tmp_path, data, "twelve_bit.nrrd"), data


def source(path, **properties) -> Network:
    network = Network()
    network.add("VolumeSource", id="src", path=str(path), **properties)
    return network


def volume_of(path, **properties):
    network = source(path, **properties)
    network.update("src.volume")
    return network.output("src.volume")


# --- the value range --------------------------------------------------------------------------
def test_the_default_range_is_the_data_min_to_max_and_robust_is_the_bulk(twelve_bit):
    path, data = twelve_bit
    assert volume_of(path).value_range == (0.0, float(OUTLIER))
    low, high = volume_of(path, window="robust").value_range
    np.testing.assert_allclose((low, high), np.percentile(data, [0.5, 99.5]))
    assert high < TWELVE_BIT_MAX  # the outlier no longer squeezes the bulk into 5 % of [0, 1]
    assert volume_of(path, window="robust", window_percentiles=[0, 100]).value_range == (0, OUTLIER)


def test_an_explicit_value_range_wins_over_the_window(twelve_bit):
    path, _ = twelve_bit
    assert volume_of(path, window="robust", value_range=[100, 900]).value_range == (100, 900)


def test_a_range_the_file_declares_is_kept_unless_the_user_asks_otherwise(tmp_path):
    path = tmp_path / "declared.nrrd"
    nrrd.write(str(path), ball(), {"min": 0, "max": 4095}, index_order="C")
    assert volume_of(path).value_range == (0, 4095)
    assert volume_of(path, window="robust").value_range[1] < TWELVE_BIT_MAX


@pytest.mark.parametrize("name, stored_max", [("ct_head_headsq/quarter.nhdr", 3926),
                                              ("dicom_mr_scout", 346)])
def test_real_scans_map_their_own_range_and_window_within_it(name, stored_max, data_dir):
    full = volume_of(data_dir / name)
    assert full.value_range == (0.0, float(stored_max))  # the scout was [0, 4095]: nearly black
    low, high = volume_of(data_dir / name, window="robust", window_percentiles=[1, 99]).value_range
    np.testing.assert_allclose((low, high), np.percentile(full.data, [1, 99]))
    assert 0 <= low < high < stored_max


def test_the_robust_window_of_float_data_is_within_a_65536th(data_dir):
    full = volume_of(data_dir / "mri_head_t1/MR.nii.gz")
    window = volume_of(data_dir / "mri_head_t1/MR.nii.gz", window="robust").value_range
    lo, hi = full.value_range
    expected = np.percentile(full.data, [0.5, 99.5])
    assert np.all(np.abs(np.subtract(window, expected)) <= (hi - lo) / 65536)


@pytest.mark.parametrize("percentiles", [[99.5, 0.5], [50, 50]])
def test_window_percentiles_must_rise_naming_the_property(percentiles, twelve_bit, tmp_path,
                                                          capsys):
    path, _ = twelve_bit
    network = source(path, window="robust", window_percentiles=percentiles)
    with pytest.raises(ProcessorError, match=r"src.window_percentiles: the low percentile must be "
                                             r"below the high one"):
        network.update("src.volume")
    document = {"format": "vgraph-network", "version": 1, "processors": [
        {"type": "VolumeSource", "id": "src",
         "properties": {"path": str(path), "window_percentiles": percentiles}}]}
    (tmp_path / "n.json").write_text(json.dumps(document))
    assert main(["validate", str(tmp_path / "n.json")]) == 2
    assert "src.window_percentiles: the low percentile must be below" in capsys.readouterr().err


def test_a_window_of_width_zero_keeps_the_full_range_with_a_warning(tmp_path):
    data = np.zeros((10, 10, 10), np.uint16)
    data[0, 0, :3] = [5, 700, 1000]  # 99.7 % background
    path = write_nrrd(tmp_path, data)
    with pytest.warns(VGraphWarning, match=r"src.window_percentiles: the 0.5th and 99.5th "
                                           r"percentiles of .*scan.nrrd are both 0; using the full "
                                           r"value range \(0.0, 1000.0\)"):
        assert volume_of(path, window="robust").value_range == (0.0, 1000.0)


def test_integer_function_volumes_keep_their_full_scale_range():
    for data_type, full_scale in (("uint8", 255.0), ("uint16", 65535.0)):
        network = Network()
        network.add("FunctionSelector", id="f", function="sphere", resolution=16, data_type=data_type)
        network.update("f.volume")
        assert network.output("f.volume").value_range == (0.0, full_scale)


# --- rendering: not black any more ----------------------------------------------------------------
def render(path, rc=None, **properties) -> np.ndarray:
    """VolumeSource -> EntryExitPoints -> RayCaster (its defaults, or ``rc``) at 48 x 48."""
    network = source(path, **properties)
    volume = volume_of(path, **properties)
    box = (volume.origin, np.add(volume.origin, volume.extent))
    network.add("EntryExitPoints", id="eep", camera=Camera.looking_at_box(*box))
    network.add("RayCaster", id="rc", **(rc or {}))
    network.link("eep.camera", "rc.camera")
    for a, b in (("src.volume", "eep.volume"), ("src.volume", "rc.volume"),
                 ("eep.entry", "rc.entry"), ("eep.exit", "rc.exit")):
        network.connect(a, b)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", VGraphWarning)  # the old range's image is blank on purpose
        return network.evaluate("rc.image", size=(48, 48))


def test_a_twelve_bit_scan_renders_through_the_standard_pipeline(tmp_path, twelve_bit):
    path = write_nrrd(tmp_path, ball())
    ramp = {"transfer_function": TransferFunctionLut.DEFAULT}  # over the normalised range
    drawn = render(path, ramp)[..., :3].max(axis=-1) > 0.05
    assert drawn.mean() > 0.05 and drawn[18:30, 18:30].all()  # the ball's core, in the middle
    assert render(path, ramp, value_range=[0, 65535])[..., :3].max() == 0.0  # the old rule: black
    # One outlier voxel puts the bulk below 5 % of min..max, under a ramp over the normalised
    # range: that is what the robust window is for ...
    outlier_path, _ = twelve_bit
    assert render(outlier_path, ramp)[..., :3].max() < 0.05
    robust = render(outlier_path, ramp, window="robust")[..., :3].max(axis=-1) > 0.05
    assert robust.sum() >= drawn.sum()
    # ... and why the RayCaster starts with the auto transfer function, placed by percentiles of
    # the voxels (issue 28): the outlier hides nothing from it, whatever the value range.
    for properties in ({}, {"value_range": [0, 65535]}):
        auto = render(outlier_path, **properties)[..., :3].max(axis=-1) > 0.05
        assert auto[18:30, 18:30].all()


# --- time points ----------------------------------------------------------------------------------
@pytest.fixture
def bold(tmp_path):
    """An fMRI-like series: 4 time points of 6 x 5 x 4 voxels, [t, z, y, x]."""
    series = np.random.default_rng(3).integers(0, 4096, size=(4, 4, 5, 6)).astype(np.int16)
    path = tmp_path / "bold.nii.gz"
    nib.save(nib.Nifti1Image(np.ascontiguousarray(series.T), np.diag([3.0, 3.0, 3.5, 1.0])), str(path))
    return path, series


def test_volume_source_reads_the_time_step_and_reports_the_count(bold):
    path, series = bold
    network = source(path)
    network.update("src.volume")
    assert network.output("src.volume").time_steps == 4
    for t in (3, 1):
        network.set("src.time_step", t)
        network.update("src.volume")
        volume = network.output("src.volume")
        np.testing.assert_array_equal(volume.data, series[t])
        assert volume.time_steps == 4 and volume.spacing == (3.0, 3.0, 3.5)


def test_a_time_step_beyond_the_file_names_the_property_and_the_count(bold, data_dir):
    path, _ = bold
    with pytest.raises(ProcessorError, match=r"src.time_step: time step 4 is out of range: "
                                             r".*bold.nii.gz holds 4 time points \(0 \.\. 3\)"):
        source(path, time_step=4).update("src.volume")
    with pytest.raises(ProcessorError, match=r"src.time_step: time step 1 is out of range: "
                                             r".*quarter.nhdr holds 1 time point \(0\)"):
        source(data_dir / "ct_head_headsq/quarter.nhdr", time_step=1).update("src.volume")


def test_the_time_step_is_saved_and_set_from_the_cli(bold, tmp_path):
    path, series = bold
    network_file = tmp_path / "bold.json"
    source(path, time_step=2).save(network_file)
    out = tmp_path / "v.npy"
    assert main(["run", str(network_file), "--set", "src.time_step=1", "--port", "src.volume",
                 "--npy", str(out)]) == 0
    np.testing.assert_array_equal(np.load(out), series[1])


# --- flat volumes ---------------------------------------------------------------------------------
FLAT = r"one voxel thick along {axis} \({dims} voxels\): .*renders as a flat plane seen face-on " \
       r"and as nothing from the side"


def test_a_single_dicom_slice_warns_that_it_is_flat(data_dir, tmp_path):
    shutil.copy(data_dir / "dicom_mr_scout/1-2.dcm", tmp_path / "1-2.dcm")
    with pytest.warns(VGraphWarning, match=r"src: .*1-2.dcm is " + FLAT.format(axis="z", dims="512 x 512 x 1")):
        volume_of(tmp_path / "1-2.dcm")


def test_one_slice_nifti_and_2d_arrays_warn_naming_the_axis(tmp_path):
    nib.save(nib.Nifti1Image(np.ones((6, 5, 1), np.float32), np.eye(4)), str(tmp_path / "one.nii"))
    with pytest.warns(VGraphWarning, match=FLAT.format(axis="z", dims="6 x 5 x 1")):
        volume_of(tmp_path / "one.nii")
    np.save(tmp_path / "line.npy", np.ones((3, 1, 1), np.float32))
    with pytest.warns(VGraphWarning, match=FLAT.format(axis="x and y", dims="1 x 1 x 3")):
        volume_of(tmp_path / "line.npy")


def test_a_thick_volume_does_not_warn(data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error", VGraphWarning)
        volume_of(data_dir / "dicom_mr_scout")  # 3 slices: thin, but a box
