"""The vgraph command: run, validate, list, exit codes and messages."""

import json
import subprocess
import sys

import numpy as np
import PIL.Image
import pytest

from vgraph.cli import main

from conftest import REPO

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
    args = ["run", str(tmp_path / "fragile.json"), "--plugin", "toy_processors", "--profile", str(tmp_path / "p.json")]
    assert main(args) == 1
    assert "processor 'f' (Fragile): ZeroDivisionError: deliberate failure" in capsys.readouterr().err
    assert [e["id"] for e in json.loads((tmp_path / "p.json").read_text())["evaluated"]] == ["n"]
