"""The vgraph command: run, validate, list, exit codes and messages."""

import json
import subprocess
import sys

import numpy as np
import PIL.Image
import pytest

from vgraph.cli import main

from helpers.paths import REPO

GRAY = REPO / "networks" / "grayscale.json"


def vgraph_cli(*args, cwd=None):
    """Run `python -m vgraph` as a user would; return (exit code, stdout, stderr)."""
    done = subprocess.run([sys.executable, "-m", "vgraph", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, timeout=300)
    return done.returncode, done.stdout, done.stderr


def test_run_writes_png_npy_and_profile(tmp_path):
    code, _, err = vgraph_cli("run", GRAY, "-o", tmp_path / "g.png", "--npy", tmp_path / "g.npy",
                              "--profile", tmp_path / "p.json", "--set", "gray.saturation=0")
    assert code == 0, err
    png = np.asarray(PIL.Image.open(tmp_path / "g.png"))
    npy = np.load(tmp_path / "g.npy")
    assert npy.dtype == np.float32 and npy.shape == (192, 192, 4)
    np.testing.assert_array_equal(png, np.round(np.clip(npy, 0, 1) * 255))
    assert np.allclose(npy[..., 0], npy[..., 1])  # saturation 0: grey
    profile = json.loads((tmp_path / "p.json").read_text())
    assert [e["id"] for e in profile["evaluated"]] == ["source", "gray", "canvas"]
    assert profile["total_seconds"] >= 0


def test_run_a_named_port_evaluates_only_its_ancestors(tmp_path):
    assert main(["run", str(GRAY), "--port", "source.image", "--npy", str(tmp_path / "s.npy"),
                 "--profile", str(tmp_path / "p.json")]) == 0
    assert [e["id"] for e in json.loads((tmp_path / "p.json").read_text())["evaluated"]] == ["source"]
    assert np.load(tmp_path / "s.npy").shape == (192, 192, 4)


@pytest.mark.parametrize("args, message", [
    (["run", "missing.json"], "missing.json: (top level): file not found"),
    (["run", str(GRAY), "--set", "gray.saturation=2"], "gray.saturation: invalid value 2"),
    (["run", str(GRAY), "--set", "gray.nothing=1"], "Grayscale has no property 'nothing'"),
    (["run", str(GRAY), "--port", "gray.nope", "-o", "x.png"], "has no outport 'nope'"),
    (["run", str(GRAY), "--plugin", "no_such_module_here"], "plug-in 'no_such_module_here' could not be imported"),
])
def test_bad_input_exits_2_with_a_message(capsys, args, message):
    assert main(args) == 2
    assert message in capsys.readouterr().err


def test_bad_size_is_a_usage_error():
    code, _, err = vgraph_cli("run", GRAY, "--size", "big")
    assert code == 2 and "size must look like 512x384" in err


def test_validate(tmp_path):
    assert vgraph_cli("validate", GRAY)[0] == 0
    bad = json.loads(GRAY.read_text())
    bad["processors"][1]["type"] = "Greyscale"
    bad["connections"].append({"from": "canvas.image", "to": "source.image"})
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    code, out, err = vgraph_cli("validate", tmp_path / "bad.json")
    assert code == 2
    assert "processors[1].type: unknown processor type 'Greyscale'" in err
    assert "connections[" in err


def test_list_json_describes_every_processor():
    code, out, _ = vgraph_cli("list", "--json")
    assert code == 0
    listing = {entry["type"]: entry for entry in json.loads(out)}
    assert {"ImageSource", "Grayscale", "ImageWriter", "Canvas"} <= set(listing)
    gray = listing["Grayscale"]
    assert gray["category"] == "Image" and gray["description"]
    assert {"name": "image", "direction": "in", "data_type": "Image", "optional": False,
            "multiple": False} in gray["ports"]
    assert {"name": "image", "direction": "out", "data_type": "Image"} in gray["ports"]
    saturation = next(p for p in gray["properties"] if p["name"] == "saturation")
    assert (saturation["type"], saturation["default"], saturation["min"], saturation["max"]) == ("float", 0.0, 0.0, 1.0)


def test_version_and_help():
    code, out, _ = vgraph_cli("--version")
    assert code == 0 and out.startswith("vgraph ")
    assert vgraph_cli()[0] == 2


def test_a_bug_inside_a_processor_exits_1_and_names_it(tmp_path, capsys):
    network = {"format": "vgraph-network", "version": 1,
               "processors": [{"id": "n", "type": "Number"}, {"id": "f", "type": "Fragile", "properties": {"fail": 1}},
                              {"id": "c", "type": "Collect"}],
               "connections": [{"from": "n.value", "to": "f.value"}, {"from": "f.value", "to": "c.value"}]}
    (tmp_path / "fragile.json").write_text(json.dumps(network))
    args = ["run", str(tmp_path / "fragile.json"), "--plugin", "helpers.toy_processors", "--profile", str(tmp_path / "p.json")]
    assert main(args) == 1
    assert "processor 'f' (Fragile): ZeroDivisionError: deliberate failure" in capsys.readouterr().err
    assert [e["id"] for e in json.loads((tmp_path / "p.json").read_text())["evaluated"]] == ["n"]


# --- --size and canvas.size: every network writes the size asked for --------------------------------
@pytest.mark.parametrize("option, shape", [(["--size", "100x60"], (60, 100, 4)),
                                           (["--set", "canvas.size=[64,48]"], (48, 64, 4))])
def test_size_holds_for_an_image_only_network(tmp_path, option, shape):
    assert main(["run", str(GRAY), *option, "-o", str(tmp_path / "g.png"), "--data", str(tmp_path / "g.npy")]) == 0
    assert np.load(tmp_path / "g.npy").shape == shape
    assert np.asarray(PIL.Image.open(tmp_path / "g.png")).shape == shape


def test_the_canvas_resamples_bilinearly_and_keeps_an_image_of_its_size():
    import vgraph
    network = vgraph.load(GRAY)
    resample = sys.modules[type(network["canvas"]).__module__].resample
    network.update()
    assert network.output("canvas") is network.output("gray.image")  # 192 x 192 already: unchanged
    native = network.evaluate("gray.image")
    small = network.evaluate("canvas", size=(48, 32))
    assert small.shape == (32, 48, 4)
    np.testing.assert_allclose(small, resample(native, (48, 32)), atol=1e-6)
    # Shrinking averages: each output pixel is near the mean of the source block it covers.
    blocks = native.reshape(32, 6, 48, 4, 4).mean(axis=(1, 3))
    assert np.abs(small - blocks).mean() < 0.02
    assert network.evaluate("gray.image").shape == (192, 192, 4)  # the port itself keeps its size


def test_the_docs_canvas_size_example_writes_that_size(tmp_path):
    code, _, err = vgraph_cli("run", GRAY, "-o", "small.png", "--set", "gray.saturation=1",
                              "--set", "canvas.size=[64,64]", cwd=tmp_path)
    assert code == 0, err
    assert PIL.Image.open(tmp_path / "small.png").size == (64, 64)


# --- no output option ----------------------------------------------------------------------------
def test_run_without_an_output_evaluates_and_says_nothing_was_written(tmp_path):
    code, out, err = vgraph_cli("run", GRAY, cwd=tmp_path)
    assert code == 0 and out == ""
    assert "vgraph: nothing written: no -o or --data given" in err
    assert "-o OUT.png" in err and "--data OUT.npz" in err
    assert "evaluated source, gray, canvas" in err
    assert list(tmp_path.iterdir()) == []


def test_run_without_an_output_names_what_the_networks_writers_wrote(tmp_path):
    network = json.loads(GRAY.read_text())
    network["processors"][0]["properties"]["path"] = str(REPO / "networks" / "data" / "color_wheel.png")
    network["processors"].append({"id": "writer", "type": "ImageWriter", "properties": {"path": "w.png"}})
    network["connections"].append({"from": "gray.image", "to": "writer.image"})
    (tmp_path / "net.json").write_text(json.dumps(network))
    code, _, err = vgraph_cli("run", tmp_path / "net.json")
    assert code == 0 and (tmp_path / "w.png").is_file()
    assert f"only the network's writers wrote (writer -> {tmp_path / 'w.png'})" in err


# --- --set file paths: relative to the current folder ---------------------------------------------
def test_set_resolves_a_file_path_against_the_current_folder(tmp_path):
    (tmp_path / "pictures").mkdir()
    picture = np.zeros((20, 30, 4), np.uint8)
    picture[..., 0], picture[..., 3] = 255, 255
    PIL.Image.fromarray(picture).save(tmp_path / "pictures" / "red.png")
    code, _, err = vgraph_cli("run", GRAY, "--set", "source.path=pictures/red.png", "--set", "gray.saturation=1",
                              "--port", "gray.image", "--data", "red.npy", cwd=tmp_path)
    assert code == 0, err
    red = np.load(tmp_path / "red.npy")
    assert red.shape == (20, 30, 4) and np.allclose(red, [1, 0, 0, 1])
    # A missing file is named by the absolute path it was looked for at.
    code, _, err = vgraph_cli("run", GRAY, "--set", "source.path=pictures/none.png", cwd=tmp_path)
    assert code == 2 and str(tmp_path / "pictures" / "none.png") in err


def test_set_resolves_a_writer_path_against_the_current_folder(tmp_path):
    network = json.loads(GRAY.read_text())
    network["processors"].append({"id": "writer", "type": "ImageWriter", "properties": {"path": "w.png"}})
    network["connections"].append({"from": "gray.image", "to": "writer.image"})
    (tmp_path / "nets").mkdir()
    (tmp_path / "nets" / "data").symlink_to(REPO / "networks" / "data")  # the .json's own path: its folder
    (tmp_path / "nets" / "net.json").write_text(json.dumps(network))
    (tmp_path / "here").mkdir()
    code, _, err = vgraph_cli("run", tmp_path / "nets" / "net.json", "--set", "writer.path=out.png",
                              cwd=tmp_path / "here")
    assert code == 0, err
    assert (tmp_path / "here" / "out.png").is_file() and not (tmp_path / "nets" / "out.png").exists()


# --- --data: the format follows the extension ------------------------------------------------------
def test_data_writes_an_image_as_npy_and_npz(tmp_path):
    assert main(["run", str(GRAY), "--data", str(tmp_path / "g.npy"), "--data", str(tmp_path / "g.npz")]) == 0
    npy = np.load(tmp_path / "g.npy")
    with np.load(tmp_path / "g.npz") as archive:
        assert list(archive) == ["image"]
        npz = archive["image"]
    assert npy.dtype == npz.dtype == np.float32 and npy.shape == (192, 192, 4)
    np.testing.assert_array_equal(npy, npz)


@pytest.fixture
def headsq(data_dir):
    from vgraph.io import read_volume
    return REPO / "networks" / "volume_nrrd_headsq.json", read_volume(data_dir / "ct_head_headsq" / "quarter.nhdr")


def test_data_writes_a_volume_with_its_geometry(tmp_path, headsq, capsys):
    import nibabel
    import nrrd
    network, original = headsq
    outputs = [str(tmp_path / f"v{ext}") for ext in (".npy", ".npz", ".nrrd", ".nii.gz")]
    assert main(["run", str(network), "--port", "source.volume", *sum((["--data", o] for o in outputs), [])]) == 0
    assert "holds the voxel values [z, y, x] only, not the spacing and origin" in capsys.readouterr().err
    spacing, origin = np.array(original.spacing), np.array(original.origin)
    assert not np.allclose(spacing, 1.0)  # headsq is anisotropic: the test can tell
    np.testing.assert_array_equal(np.load(outputs[0]), original.data)
    with np.load(outputs[1]) as archive:
        np.testing.assert_array_equal(archive["data"], original.data)
        np.testing.assert_allclose(archive["spacing"], spacing)
        np.testing.assert_allclose(archive["origin"], origin)
    data, header = nrrd.read(outputs[2], index_order="C")
    np.testing.assert_array_equal(data, original.data)
    np.testing.assert_allclose(np.diag(header["space directions"]), spacing)
    np.testing.assert_allclose(header["space origin"], origin)
    image = nibabel.load(outputs[3])
    np.testing.assert_allclose(image.header.get_zooms()[:3], spacing)
    np.testing.assert_allclose(np.abs(image.affine[:3, 3]), np.abs(origin))
    assert np.asarray(image.dataobj).size == original.data.size


def test_an_npz_volume_reads_back_with_its_value_range(tmp_path):
    network = {"format": "vgraph-network", "version": 1,
               "processors": [{"id": "f", "type": "FunctionSelector", "properties": {"function": "sphere",
                                                                                    "resolution": 16}}]}
    (tmp_path / "f.json").write_text(json.dumps(network))
    assert main(["run", str(tmp_path / "f.json"), "--port", "f.volume", "--data", str(tmp_path / "f.npz")]) == 0
    from vgraph.io import read_volume
    import vgraph
    expected = vgraph.load(tmp_path / "f.json")
    expected.update("f.volume")
    volume, written = expected.output("f.volume"), read_volume(tmp_path / "f.npz")
    np.testing.assert_array_equal(written.data, volume.data)
    assert written.spacing == volume.spacing and written.origin == volume.origin
    assert written.value_range == volume.value_range


@pytest.mark.parametrize("args, message", [
    (["--data", "x.nrrd"], "--data {tmp}/x.nrrd: canvas carries an image; .nrrd holds volumes only: use .npy or .npz"),
    (["--data", "x.tif"], "--data {tmp}/x.tif: the extension chooses the format: .npy or .npz"),
    (["--port", "source.image", "--data", "x.nii.gz"], "source.image carries an image; .nii.gz holds volumes only"),
    (["--data", "missing/x.npz"], "the folder '{tmp}/missing' does not exist"),
])
def test_data_that_cannot_be_written_is_refused_before_evaluating(tmp_path, capsys, args, message):
    args = [a if a.startswith("-") or "." not in a or "source" in a else str(tmp_path / a) for a in args]
    assert main(["run", str(GRAY), *args, "--profile", str(tmp_path / "p.json")]) == 2
    assert message.format(tmp=tmp_path) in capsys.readouterr().err
    assert not (tmp_path / "p.json").exists()  # nothing was evaluated


def test_o_refuses_a_volume_before_evaluating(tmp_path, capsys):
    network = {"format": "vgraph-network", "version": 1,
               "processors": [{"id": "f", "type": "FunctionSelector", "properties": {"resolution": 16}}]}
    (tmp_path / "f.json").write_text(json.dumps(network))
    assert main(["run", str(tmp_path / "f.json"), "--port", "f.volume", "-o", str(tmp_path / "f.png")]) == 2
    assert "f.volume carries a volume; -o writes images only: use --data OUT.npz" in capsys.readouterr().err


def test_npy_still_works_but_is_deprecated(tmp_path):
    code, _, err = vgraph_cli("run", GRAY, "--npy", tmp_path / "g.npy")
    assert code == 0 and np.load(tmp_path / "g.npy").shape == (192, 192, 4)
    assert f"--npy is deprecated; use --data {tmp_path / 'g.npy'}" in err


# --- vgraph list ---------------------------------------------------------------------------------
def test_list_shows_choices_ranges_and_defaults():
    code, out, _ = vgraph_cli("list")
    assert code == 0
    for line in ("compositing (option: dvr|mip|iso|first_hit|xray) = 'dvr'",
                 "sampling_rate (float 0.05..16) = 1.0",
                 "saturation (float 0..1) = 0.0",
                 "size (2 ints 1..16384) = [512, 512]",
                 "raw_offset (int >= -1) = 0",
                 "path (file_path, written: *.png) = 'out.png'",
                 "camera (camera) = perspective camera, fov 30, frames the data, automatic near/far"):
        assert line in out, line
    assert max(len(line) for line in out.splitlines() if "camera" in line or "transfer_function" in line) < 120


# --- --profile after a failure -------------------------------------------------------------------
def test_the_profile_of_a_failed_run_names_the_failed_processor(tmp_path):
    network = {"format": "vgraph-network", "version": 1,
               "processors": [{"id": "n", "type": "Number"}, {"id": "f", "type": "Fragile", "properties": {"fail": 1}},
                              {"id": "c", "type": "Collect"}],
               "connections": [{"from": "n.value", "to": "f.value"}, {"from": "f.value", "to": "c.value"}]}
    (tmp_path / "fragile.json").write_text(json.dumps(network))
    code, _, err = vgraph_cli("run", tmp_path / "fragile.json", "--plugin", "helpers.toy_processors",
                              "--profile", tmp_path / "p.json", cwd=REPO / "tests")
    assert code == 1, err
    profile = json.loads((tmp_path / "p.json").read_text())
    assert [e["id"] for e in profile["evaluated"]] == ["n"]
    failed = profile["failed"]
    assert (failed["id"], failed["type"], failed["error"]) == ("f", "Fragile", "ZeroDivisionError: deliberate failure")
    assert 0 <= failed["seconds"] <= profile["total_seconds"]


# --- warnings ------------------------------------------------------------------------------------
WARNING_PLUGIN = '''
import warnings
import vgraph
from vgraph.scheduler import BlankImageWarning


class Warner(vgraph.Processor):
    """Warns three ways."""
    category = "Test"
    outports = [vgraph.Outport("value", float)]

    def process(self):
        warnings.warn(vgraph.VGraphWarning("the volume is flat:\\nall voxels are 0"))
        warnings.warn(BlankImageWarning("the image is empty"))
        warnings.warn("an ordinary warning")
        return 1.0


vgraph.register(Warner)
'''


def test_vgraph_warnings_print_as_one_line_and_others_as_python_does(tmp_path):
    (tmp_path / "warning_plugin.py").write_text(WARNING_PLUGIN)
    network = {"format": "vgraph-network", "version": 1, "processors": [{"id": "w", "type": "Warner"}]}
    (tmp_path / "w.json").write_text(json.dumps(network))
    code, _, err = vgraph_cli("run", "w.json", "--plugin", "warning_plugin", "--port", "w.value",
                              "--data", "w.npy", cwd=tmp_path)
    assert code == 0, err
    lines = err.splitlines()
    assert "vgraph: warning: the volume is flat: all voxels are 0" in lines
    assert "vgraph: warning: the image is empty" in lines
    assert not any("VGraphWarning" in line or "BlankImageWarning" in line for line in lines)
    assert any(line.endswith("UserWarning: an ordinary warning") and "warning_plugin.py:" in line for line in lines)


# --- --view -------------------------------------------------------------------------------------
HEAD = REPO / "networks" / "raycast_head.json"


def head_from_python(view: str, size=(128, 128)) -> np.ndarray:
    """What docs/reference/general/cli.md shows for scripts."""
    import vgraph
    net = vgraph.load(HEAD)
    for processor in net.processors.values():
        for name, prop in processor.properties.items():
            if prop.kind == "camera":
                address = f"{processor.id}.{name}"
                net.set(address, net.get(address).viewed_from(view))
    return net.evaluate("canvas", size=size)


def test_view_renders_named_views_that_frame_the_whole_head(tmp_path, data_dir):
    images = {}
    for view in ("front", "top"):
        out = tmp_path / f"{view}.npy"
        assert main(["run", str(HEAD), "--view", view, "--size", "128x128", "--data", str(out)]) == 0
        image = images[view] = np.load(out)
        drawn = image[..., :3].max(axis=-1) > 0.02
        assert 0.1 < drawn.mean() < 0.9, view
        border = np.concatenate([drawn[0], drawn[-1], drawn[:, 0], drawn[:, -1]])
        assert not border.any(), f"{view}: the head touches the border"
        np.testing.assert_array_equal(image, head_from_python(view))  # the same as from a script
    assert np.abs(images["front"] - images["top"]).mean() > 0.02
    assert np.mean((images["front"][..., :3].max(-1) > 0.02) != (images["top"][..., :3].max(-1) > 0.02)) > 0.05


def test_an_unknown_view_is_a_usage_error_listing_the_names():
    code, _, err = vgraph_cli("run", GRAY, "--view", "sideways")
    assert code == 2
    assert "invalid choice: 'sideways'" in err and "'front'" in err and "'anterior'" in err


def test_view_on_a_network_without_camera_warns(tmp_path):
    code, _, err = vgraph_cli("run", GRAY, "--view", "top", "--data", tmp_path / "g.npy")
    assert code == 0 and "vgraph: warning: --view top: the network has no camera to turn" in err


def test_set_reads_a_transfer_function_file_from_the_current_folder(tmp_path, data_dir):
    from vgraph.transfer_function import PRESETS, TransferFunction
    red = TransferFunction(points=[[0.0, 1.0, 0.0, 0.0, 0.0], [0.3, 1.0, 0.0, 0.0, 1.0], [1.0, 1.0, 0.0, 0.0, 1.0]])
    red.save(tmp_path / "red.json")
    head = REPO / "networks" / "raycast_head.json"
    code, _, err = vgraph_cli("run", head, "--set", "rc.transfer_function=red.json", "--set", "rc.shading=none",
                              "--size", "48x48", "--data", "red.npy", cwd=tmp_path)
    assert code == 0, err
    image = np.load(tmp_path / "red.npy")
    drawn = image[..., 3] * image[..., :3].max(axis=-1) > 0.05
    assert drawn.any() and np.all(image[drawn][:, 1:3] < 1e-3)  # red only: the file was read
    preset = next(iter(PRESETS))
    assert vgraph_cli("run", head, "--set", f"rc.transfer_function={preset}", "--size", "16x16", cwd=tmp_path)[0] == 0
