"""Every user string on its way to the system (file names, transfer-function names, --set values,
option paths) is bounded and encodable, or refused with exit 2 naming its place; a memory failure
anywhere in ``vgraph run`` names the size that failed and the memory that would do."""

import json
import re
import resource
import subprocess
import sys

import numpy as np
import pytest

import vgraph
from vgraph import FloatProperty, Outport, Processor
from vgraph.cli import main
from vgraph.file_names import NAME_MAX, file_name_problem

from helpers.paths import REPO

SPHERE = REPO / "networks" / "raycast_sphere.json"
LONG_NAME = "a" * 5000


def sphere_with(tmp_path, change) -> str:
    """raycast_sphere.json with ``change(document)`` applied, saved in tmp_path."""
    document = json.loads(SPHERE.read_text())
    change(document)
    path = tmp_path / "net.json"
    path.write_text(json.dumps(document))
    return str(path)


def ray_caster(document) -> dict:
    return next(p for p in document["processors"] if p["id"] == "rc")


def with_image_writer(path: str):
    def change(document):
        document["processors"].append({"id": "w", "type": "ImageWriter", "properties": {"path": path}})
        document["connections"].append({"from": "rc.image", "to": "w.image"})
    return change


def refused(capsys, argv, *patterns) -> str:
    """Runs the command: exit 2 (argparse's usage errors exit from main), no traceback, nothing
    evaluated, a message that stays short and matches every pattern."""
    try:
        code = main(argv)
    except SystemExit as usage_error:
        code = usage_error.code
    assert code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "internal error" not in err and "evaluated" not in err, err
    assert len(err) < 1500, f"the message repeats the whole value: {len(err)} characters"
    for pattern in patterns:
        assert re.search(pattern, err), err
    return err


# --- --set values ---------------------------------------------------------------------------------
@pytest.mark.parametrize("value", ["[" * 5000, "[" * 100 + "]" * 100, '{"a":' * 3000 + "1" + "}" * 3000])
def test_a_set_value_nested_deeper_than_a_network_file_may_be_is_refused_naming_the_property(capsys, value):
    refused(capsys, ["run", str(SPHERE), "--set", f"canvas.size={value}"],
            r"canvas\.size: the --set value '[\[{]", r"nested more than 64 levels deep")


def test_a_set_value_nested_as_deep_as_a_network_file_may_be_is_judged_by_its_property(capsys):
    refused(capsys, ["run", str(SPHERE), "--set", f"canvas.size={'[' * 64}{']' * 64}"],
            r"canvas\.size: invalid value")


# --- transfer-function names ----------------------------------------------------------------------
def test_a_5000_character_transfer_function_name_in_a_file_is_refused_naming_the_json_path(tmp_path, capsys):
    network = sphere_with(tmp_path, lambda d: ray_caster(d)["properties"].update(transfer_function=LONG_NAME))
    refused(capsys, ["validate", network], r"processors\[2\]\.properties\.transfer_function: ",
            "at most 4095 bytes", "neither a preset")
    refused(capsys, ["run", network], r"processors\[2\]\.properties\.transfer_function: ")


def test_a_5000_character_transfer_function_name_through_set_is_refused_naming_the_property(capsys):
    refused(capsys, ["run", str(SPHERE), "--set", f"rc.transfer_function={LONG_NAME}"],
            r"rc\.transfer_function: ", "at most 4095 bytes")


def test_a_long_transfer_function_path_is_refused_by_its_folder_names_too(capsys):
    refused(capsys, ["run", str(SPHERE), "--set", f"rc.transfer_function={'d' * 300}/tf.json"],
            r"rc\.transfer_function: ", rf"at most {NAME_MAX} bytes")


def test_a_lone_surrogate_in_a_transfer_function_name_is_refused_naming_the_place(tmp_path, capsys):
    network = sphere_with(tmp_path, lambda d: ray_caster(d)["properties"].update(transfer_function="x\ud800y"))
    refused(capsys, ["validate", network], r"processors\[2\]\.properties\.transfer_function: ",
            r"surrogates not allowed")
    refused(capsys, ["run", str(SPHERE), "--set", "rc.transfer_function=x\ud800y"],
            r"rc\.transfer_function: ", r"surrogates not allowed")


def test_a_transfer_function_file_nested_100000_deep_is_refused_naming_the_file(tmp_path, capsys):
    (tmp_path / "deep.json").write_text('{"points": ' + "[" * 100000 + "]" * 100000 + "}")
    network = sphere_with(tmp_path, lambda d: ray_caster(d)["properties"].update(transfer_function="deep.json"))
    refused(capsys, ["validate", network], r"processors\[2\]\.properties\.transfer_function: ",
            r"deep\.json: nested more than 64 levels deep")


def test_a_transfer_function_file_larger_than_one_can_be_is_not_read(tmp_path, capsys):
    from vgraph.transfer_function import MAX_FILE_BYTES
    with open(tmp_path / "huge.json", "wb") as file:
        file.truncate(MAX_FILE_BYTES + 1)  # sparse: nothing to write
    network = sphere_with(tmp_path, lambda d: ray_caster(d)["properties"].update(transfer_function="huge.json"))
    refused(capsys, ["validate", network], r"huge\.json: ", "larger than a transfer-function file can be")


# --- file paths -----------------------------------------------------------------------------------
def test_an_image_writer_path_with_a_300_character_name_is_refused_by_validate_and_run(tmp_path, capsys):
    network = sphere_with(tmp_path, with_image_writer("b" * 300 + ".png"))
    refused(capsys, ["validate", network], r"processors\[4\]\.properties\.path: ", rf"at most {NAME_MAX} bytes")
    refused(capsys, ["run", network], r"processors\[4\]\.properties\.path: ")


def test_a_writer_path_longer_than_a_path_may_be_is_refused(tmp_path, capsys):
    network = sphere_with(tmp_path, with_image_writer("/".join(["d" * 200] * 21) + ".png"))
    refused(capsys, ["validate", network], r"processors\[4\]\.properties\.path: ", "at most 4095 bytes")


def test_the_home_folder_of_a_user_who_does_not_exist_is_a_plain_folder_name(tmp_path, capsys):
    """pathlib's expanduser raised RuntimeError for '~nosuchuser' (exit 1); a shell leaves it."""
    network = sphere_with(tmp_path, with_image_writer("~nosuchuser_vgraph/w.png"))
    assert main(["validate", network]) == 0
    refused(capsys, ["run", network, "--set", "rc.transfer_function=~nosuchuser_vgraph/tf.json"],
            r"rc\.transfer_function: .*'~nosuchuser_vgraph/tf.json' is neither a preset")


@pytest.mark.parametrize("option", ["-o", "--data", "--profile"])
def test_output_options_with_a_name_too_long_exit_2_naming_the_option_path(tmp_path, capsys, option):
    suffix = {"-o": ".png", "--data": ".npz", "--profile": ".json"}[option]
    refused(capsys, ["run", str(SPHERE), option, str(tmp_path / ("o" * 300 + suffix))],
            rf"at most {NAME_MAX} bytes")


@pytest.mark.parametrize("command", [["run"], ["validate"], ["convert"]])
@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_input_paths_with_a_name_too_long_exit_2(tmp_path, capsys, command, suffix):
    extra = [str(tmp_path / "x.zarr"), "--quiet"] if command == ["convert"] else []
    refused(capsys, [*command, str(tmp_path / ("n" * 300 + suffix)), *extra], rf"at most {NAME_MAX} bytes")


def test_a_convert_output_with_a_name_too_long_exit_2(tmp_path, capsys):
    np.save(tmp_path / "small.npy", np.zeros((4, 4, 4), np.uint8))
    refused(capsys, ["convert", str(tmp_path / "small.npy"), str(tmp_path / ("z" * 300 + ".zarr")), "--quiet"],
            rf"at most {NAME_MAX} bytes")


def test_allow_write_folders_are_bounded_too(tmp_path, capsys):
    refused(capsys, ["validate", str(SPHERE), "--allow-write", "f" * 300], rf"at most {NAME_MAX} bytes")


@pytest.mark.parametrize("text, reason", [
    ("a\0b", "NUL byte"), ("x\ud800", "surrogates not allowed"), ("n" * 256, "at most 255 bytes"),
    ("\u00e9" * 128, "at most 255 bytes"), ("d/" * 2048, "at most 4095 bytes"),
])
def test_file_name_problems_are_named(text, reason):
    assert reason in file_name_problem(text)


@pytest.mark.parametrize("text", ["n" * 255, "\u00e9" * 127, "caf\udce9.nrrd", "d/" * 2047])
def test_names_the_system_takes_are_not_problems(text):
    assert file_name_problem(text) is None


# --- memory ---------------------------------------------------------------------------------------
class Hungry(Processor):
    """Allocates ``gib`` GiB of float64 (a test processor: out of memory on purpose)."""
    outports = [Outport("value", float)]
    gib = FloatProperty(1.0, min=0.0)

    def process(self):
        if self.gib == 0:
            raise MemoryError  # the bare kind: Python's own allocations, bytes copies
        return float(np.empty(int(self.gib * 2**27)).size)


vgraph.register(Hungry)


def hungry_network(tmp_path, gib: float) -> str:
    document = {"format": "vgraph-network", "version": 2,
                "processors": [{"id": "eater", "type": "Hungry", "properties": {"gib": gib}}]}
    path = tmp_path / "hungry.json"
    path.write_text(json.dumps(document))
    return str(path)


def test_a_processor_out_of_memory_names_the_size_that_failed_and_the_memory_that_would_do(tmp_path, capsys):
    err = refused(capsys, ["run", hungry_network(tmp_path, 1024.0), "--port", "eater.value"],
                  r"processor 'eater' \(Hungry\): out of memory: allocating 1\.0 TiB failed",
                  r"available")
    assert "MemoryError" not in err


def test_a_bare_memory_error_is_named_with_the_memory_there_was(tmp_path, capsys):
    refused(capsys, ["run", hungry_network(tmp_path, 0), "--port", "eater.value"],
            r"processor 'eater' \(Hungry\): out of memory: an allocation of unknown size failed",
            r"available")


def test_a_memory_error_outside_any_processor_is_named_too(monkeypatch, capsys):
    def no_memory(*args, **kwargs):
        raise MemoryError
    monkeypatch.setattr(vgraph, "load", no_memory)
    refused(capsys, ["validate", str(SPHERE)], r"vgraph: error: out of memory")


def test_the_budget_named_under_an_address_space_limit_is_what_is_used_plus_what_failed(monkeypatch):
    from vgraph import memory
    monkeypatch.setattr(memory, "address_space", lambda: (3 * 2**30, 4 * 2**30))
    monkeypatch.setattr(memory, "available_memory", lambda: 2**30)
    text = memory.out_of_memory_reason("reading x", size=2 * 2**30)
    assert text == ("out of memory: allocating 2.0 GiB failed while reading x: the process holds "
                    "3.0 GiB of its 4.0 GiB address-space limit (ulimit -v); a limit of at least "
                    "5.0 GiB would do")


def _address_limit(limit):
    return lambda: resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


def test_a_1_gib_npz_under_a_6_gb_address_limit_is_refused_naming_the_size_and_what_would_do(tmp_path):
    """The red team's case: 1024^3 uint8 (a legitimate 1 GiB file) whose 2 GiB R16 texture does
    not fit; it ended in a bare MemoryError (exit 1)."""
    volume = np.zeros((1024, 1024, 1024), np.uint8)
    volume[256:768, 256:768, 256:768] = 200
    np.savez(tmp_path / "big.npz", data=volume)
    del volume
    done = subprocess.run([sys.executable, "-m", "vgraph", "run", str(tmp_path / "big.npz"), "-o",
                           str(tmp_path / "big.png"), "--size", "32x32"], capture_output=True, text=True,
                          timeout=600, preexec_fn=_address_limit(6 * 10**9))
    (tmp_path / "big.npz").unlink()
    assert "Traceback" not in done.stderr and "MemoryError" not in done.stderr
    if done.returncode == 0:  # a GL that holds a 2 GiB texture (llvmpipe holds 1 GiB at most)
        assert (tmp_path / "big.png").is_file()
        return
    assert done.returncode == 2, done.stderr
    assert re.search(r"processor 'rc' \(RayCaster\): out of memory: .*2\.0 GiB", done.stderr), done.stderr
    assert re.search(r"would do|brick by brick", done.stderr), done.stderr
    assert not (tmp_path / "big.png").exists()


def test_a_memory_error_while_reading_a_volume_names_the_file_and_the_size(tmp_path, monkeypatch):
    import vgraph.io
    from vgraph.io import read_volume
    np.save(tmp_path / "v.npy", np.zeros((4, 4, 4), np.uint8))

    def reader_out_of_memory(*args, **kwargs):
        return np.empty(2**40)  # 8 TiB: numpy's MemoryError, which knows its size
    monkeypatch.setitem(vgraph.io._READERS, ".npy", reader_out_of_memory)
    with pytest.raises(vgraph.VolumeFileError, match=r"v\.npy: out of memory: allocating 8\.0 TiB failed "
                                                      r"while reading it: "):
        read_volume(tmp_path / "v.npy")


def test_a_volume_path_too_long_is_a_volume_file_error_from_python_too(tmp_path):
    from vgraph.io import read_volume
    with pytest.raises(vgraph.VolumeFileError, match="File name too long"):
        read_volume(tmp_path / ("v" * 300 + ".nrrd"))
    with pytest.raises(vgraph.VolumeFileError, match="File name too long"):
        read_volume(tmp_path / ("v" * 300))


def test_an_animation_pattern_whose_frame_names_are_too_long_is_refused_in_a_short_message(tmp_path, capsys):
    refused(capsys, ["animate", str(SPHERE), "-o", str(tmp_path / "f" / "{:5000d}.png"), "--frames", "1",
                     "--quiet"], "at most 4095 bytes")
