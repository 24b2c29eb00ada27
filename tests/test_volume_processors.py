"""VolumeSource, FunctionSelector, CubicSplineProcessor and VolumeWriter, as users run them:
through `vgraph run` on the shipped networks and against each format's reference library."""

import json

import nibabel
import numpy as np
import pydicom
import pytest
import scipy.ndimage

import vgraph
from vgraph import Network, ProcessorError
from vgraph.cli import main
from vgraph.implicit import DATA_TYPES, FUNCTIONS
from vgraph.io import read_volume

from helpers.paths import REPO

NETWORKS = REPO / "networks"


def nifti_zyx(path, scaled=True):
    image = nibabel.load(path)
    data = image.get_fdata(dtype=np.float32) if scaled else np.asarray(image.dataobj)
    return np.asarray(data).transpose(2, 1, 0)


def dicom_stack(folder):
    slices = [pydicom.dcmread(p) for p in folder.glob("*.dcm")]
    slices.sort(key=lambda s: float(s.ImagePositionPatient[2]))
    return np.stack([s.pixel_array for s in slices])


REFERENCES = {  # network, path override (or None), reference reader
    "neghip": ("volume_qvis_neghip", None,
               lambda d: np.fromfile(d / "sim_neghip/neghip_66x66x66_uint8.raw", np.uint8).reshape(66, 66, 66)),
    "hydrogen": ("volume_raw_hydrogen", None,
                 lambda d: np.fromfile(d / "sim_hydrogen/hydrogen_64x64x64_float32.raw", "<f4").reshape(64, 64, 64)),
    "headsq": ("volume_nrrd_headsq", None, lambda d: np.concatenate(
        [np.fromfile(d / f"ct_head_headsq/quarter.{k}", "<i2") for k in range(1, 94)]).reshape(93, 64, 64)),
    "engine": ("volume_nifti_engine", None, lambda d: nifti_zyx(d / "ct_engine/engine.nii.gz", scaled=False)),
    "bonsai": ("volume_nifti_engine", "ct_bonsai/bonsai.nii.gz",
               lambda d: nifti_zyx(d / "ct_bonsai/bonsai.nii.gz", scaled=False)),
    "mri_t1": ("volume_nifti_engine", "mri_head_t1/MR.nii.gz", lambda d: nifti_zyx(d / "mri_head_t1/MR.nii.gz")),
    "mri_tiny": ("volume_metaimage_head", None,
                 lambda d: np.fromfile(d / "mri_head_tiny/HeadMRVolume.raw", np.uint8).reshape(42, 62, 48)),
    "dicom": ("volume_dicom_scout", None, lambda d: dicom_stack(d / "dicom_mr_scout")),
    "stent": ("volume_numpy_stent", None, lambda d: np.load(d / "cta_stent/stent.npz")["arr_0"]),
}


@pytest.mark.parametrize("name", REFERENCES)
def test_every_shared_data_set_loads_through_vgraph_run(name, data_dir, tmp_path):
    network, override, reference = REFERENCES[name]
    args = ["run", str(NETWORKS / f"{network}.json"), "--port", "source.volume", "--npy", str(tmp_path / "v.npy")]
    if override:
        args += ["--set", f"source.path={data_dir / override}"]
    assert main(args) == 0
    loaded, expected = np.load(tmp_path / "v.npy"), reference(data_dir)
    assert loaded.shape == expected.shape
    np.testing.assert_allclose(loaded, expected, rtol=1e-6)


@pytest.mark.parametrize("network", sorted(p.stem for p in NETWORKS.glob("volume_*.json")))
def test_volume_networks_write_their_volume(network, data_dir, tmp_path):
    out = tmp_path / "sub" / "v.nii.gz"
    assert main(["run", str(NETWORKS / f"{network}.json"), "--set", f"writer.path={out}"]) == 0
    written = read_volume(out)
    source = vgraph.load(NETWORKS / f"{network}.json")
    source.update("source.volume")
    assert written.data.shape == source.output("source.volume").data.shape


def test_overrides_replace_what_the_file_says(data_dir):
    network = vgraph.load(NETWORKS / "volume_nrrd_headsq.json")
    network.set("source.spacing", [1, 1, 2])
    network.set("source.origin", [5, 6, 7])
    network.set("source.value_range", [0, 4000])
    network.update("source.volume")
    volume = network.output("source.volume")
    assert (volume.spacing, volume.origin, volume.value_range) == ((1, 1, 2), (5, 6, 7), (0, 4000))


def test_source_errors_name_processor_and_file(tmp_path):
    network = Network()
    network.add("VolumeSource", id="src")
    with pytest.raises(ProcessorError, match=r"'src' \(VolumeSource\): src.path: no volume file chosen"):
        network.update("src.volume")
    (tmp_path / "cut.raw").write_bytes(bytes(100))
    network.set("src.path", str(tmp_path / "cut.raw"))
    network.set("src.raw_dims", [8, 8, 8])
    with pytest.raises(ProcessorError, match=r"cut.raw.*512.*100"):
        network.update("src.volume")


@pytest.mark.parametrize("function", FUNCTIONS)
@pytest.mark.parametrize("data_type", DATA_TYPES)
def test_function_selector_makes_every_function_in_every_type(function, data_type):
    network = Network()
    network.add("FunctionSelector", id="f", function=function, resolution=16, data_type=data_type)
    volume = network.evaluate("f.volume")
    assert volume.shape == (16, 16, 16) and volume.dtype == np.dtype(data_type)
    intensities = network.output("f.volume").normalized(volume)
    assert intensities.min() < 0.5 < intensities.max()  # the surface (level 0.5) is inside the box


def test_function_selector_parameters_are_checked():
    network = Network()
    network.add("FunctionSelector", id="f", function="torus", parameters={"minor_radius": 2.0})
    with pytest.raises(ProcessorError, match=r"'f' \(FunctionSelector\): .*'minor_radius': must be in"):
        network.update("f.volume")


def spline_network(source_volume_network=None):
    network = Network()
    network.add("FunctionSelector", id="f", function="genus2", resolution=48, data_type="uint8")
    network.add("CubicSplineProcessor", id="spline")
    network.connect("f.volume", "spline.volume")
    return network


def test_spline_coefficients_match_scipy_and_are_marked():
    network = spline_network()
    coefficients = network.evaluate("spline.volume")
    samples = network.output("f.volume")
    reference = scipy.ndimage.spline_filter(samples.data.astype(np.float64), order=3, mode="mirror")
    np.testing.assert_allclose(coefficients, reference, rtol=0, atol=1e-6 * np.abs(reference).max())
    result = network.output("spline.volume")
    assert result.is_spline_coefficients and result.value_range == samples.value_range
    assert result.spacing == samples.spacing and coefficients.dtype == np.float32


@pytest.mark.parametrize("name", ["headsq", "engine", "mri_tiny", "hydrogen"])
def test_spline_matches_scipy_on_real_data(name, data_dir):
    network_name, _, reference = REFERENCES[name]
    network = vgraph.load(NETWORKS / f"{network_name}.json")
    network.add("CubicSplineProcessor", id="spline")
    network.connect("source.volume", "spline.volume")
    coefficients = network.evaluate("spline.volume")
    expected = scipy.ndimage.spline_filter(reference(data_dir).astype(np.float64), order=3, mode="mirror")
    np.testing.assert_allclose(coefficients, expected, rtol=0, atol=2e-7 * np.abs(expected).max())


def test_spline_disabled_passes_through_and_twice_is_refused():
    network = spline_network()
    network.set("spline.enabled", False)
    network.update("spline.volume")
    assert network.output("spline.volume") is network.output("f.volume")
    network.set("spline.enabled", True)
    network.add("CubicSplineProcessor", id="again")
    network.connect("spline.volume", "again.volume")
    with pytest.raises(ProcessorError, match="already holds B-spline coefficients: remove one"):
        network.update("again.volume")


def test_spline_of_nonfinite_voxels_stays_finite():
    data = np.ones((8, 8, 8), np.float32)
    data[4, 4, 4] = np.nan
    data[1, 2, 3] = np.inf

    class Source(vgraph.Processor):
        outports = [vgraph.Outport("volume", vgraph.Volume)]

        def process(self):
            return vgraph.Volume(data)

    network = Network()
    network.add(Source, id="src")
    network.add("CubicSplineProcessor", id="spline")
    network.connect("src.volume", "spline.volume")
    with pytest.warns(UserWarning, match="2 NaN/Inf voxels replaced"):
        assert np.isfinite(network.evaluate("spline.volume")).all()


def test_volume_writer_round_trip_keeps_geometry(tmp_path):
    network = Network()
    network.add("FunctionSelector", id="f", function="sphere", resolution=20, data_type="uint16")
    network.add("VolumeWriter", id="w", path=str(tmp_path / "sphere.nrrd"))
    network.connect("f.volume", "w.volume")
    network.update()
    written, original = read_volume(tmp_path / "sphere.nrrd"), network.output("f.volume")
    np.testing.assert_array_equal(written.data, original.data)
    np.testing.assert_allclose(written.spacing, original.spacing)
    np.testing.assert_allclose(written.origin, original.origin)


def test_volume_port_npy_from_the_cli(tmp_path):
    assert main(["run", str(NETWORKS / "volume_spline_torus.json"), "--port", "spline.volume",
                 "--npy", str(tmp_path / "c.npy"), "--profile", str(tmp_path / "p.json")]) == 0
    assert np.load(tmp_path / "c.npy").shape == (64, 64, 64)
    assert [e["id"] for e in json.loads((tmp_path / "p.json").read_text())["evaluated"]] == ["source", "spline"]
