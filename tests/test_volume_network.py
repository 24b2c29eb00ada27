"""A volume file instead of a network: `vgraph.load(FILE)`, `vgraph run FILE` and opening it in the
GUI give the standard rendering network, which shows something on data it has never seen."""

import numpy as np
import pytest
from PIL import Image as PILImage

import vgraph
from vgraph.cli import main
from vgraph.volume_network import is_volume_path


VOLUMES = ["mri_head_t1/MR.nii.gz", "ct_head_headsq/quarter.nhdr", "ct_engine/engine.nii.gz",
           "cta_stent/stent.npz", "sim_hydrogen/hydrogen.vti", "sim_neghip/neghip.slc"]


def hit_fraction(image: np.ndarray) -> float:
    return float((image[..., :3].max(axis=-1) > 0.05).mean())


@pytest.mark.parametrize("name", VOLUMES)
def test_any_shipped_volume_renders_framed_and_visible_on_the_first_try(data_dir, name):
    network = vgraph.load(data_dir / name)
    image = network.evaluate("canvas", size=(96, 96))
    assert 0.05 < hit_fraction(image) < 0.95                     # something, not everything ...
    lit = image[..., :3].max(axis=-1) > 0.05
    assert not (lit[0].any() or lit[-1].any() or lit[:, 0].any() or lit[:, -1].any())  # ... all of it


def test_a_dicom_folder_is_a_volume_and_a_json_file_is_a_network(data_dir, tmp_path):
    assert is_volume_path(data_dir / "dicom_mr_scout") and is_volume_path(tmp_path / "x.nii.gz")
    assert not is_volume_path(tmp_path / "net.json")
    network = vgraph.load(data_dir / "mri_head_tiny" / "HeadMRVolume.mhd")
    assert set(network.processors) == {"source", "eep", "rc", "canvas"}


def test_vgraph_run_on_a_file_with_a_preset_and_a_view(data_dir, tmp_path, capsys):
    out = tmp_path / "head.png"
    assert main(["run", str(data_dir / "mri_head_t1" / "MR.nii.gz"), "-o", str(out), "--size", "80x60",
                 "--set", "rc.transfer_function=mri-brain"]) == 0
    pixels = np.asarray(PILImage.open(out))
    assert pixels.shape == (60, 80, 4) and hit_fraction(pixels / 255.0) > 0.05


def test_the_gui_opens_a_volume_as_an_untitled_network(window, data_dir):
    window.workspace.open(data_dir / "mri_head_tiny" / "HeadMRVolume.mhd")
    assert window.workspace.path is None     # Save asks for a name: the volume is never overwritten
    assert window.workspace.network.get("source.path").endswith("HeadMRVolume.mhd")
