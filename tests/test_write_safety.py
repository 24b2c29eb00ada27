"""Writes stay where the user allows and never lose a file: network files cannot send writers
outside their folder, every failed write is an exit-2 error naming the path (before a long
evaluation where it can be known), and temporary files of killed writers are cleaned up."""

import errno
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

import vgraph
from vgraph.atomic import atomic_path, write_text_atomic
from vgraph.cli import main
from helpers.paths import REPO

NETWORK = REPO / "networks" / "volume_spline_torus.json"


def network_writing_to(tmp_path, path: str):
    document = json.loads(NETWORK.read_text())
    writer = next(p for p in document["processors"] if p["type"] == "VolumeWriter")
    writer["properties"]["path"] = path
    folder = tmp_path / "received"
    folder.mkdir(exist_ok=True)
    (folder / "net.json").write_text(json.dumps(document))
    return folder / "net.json"


@pytest.mark.parametrize("path", ["../escaped.nrrd", "~/escaped.nrrd", "/tmp/escaped.nrrd",
                                  "sub/../../escaped.nrrd"])
def test_a_network_file_cannot_write_outside_its_folder(tmp_path, path, capsys):
    network = network_writing_to(tmp_path, path)
    with pytest.raises(vgraph.WritePathError, match=r"processors\[\d\]\.properties\.path: writer "
                                                    r"\(VolumeWriter\) would write .*escaped.nrrd, outside"):
        vgraph.load(network)
    assert main(["run", str(network)]) == 2
    assert "--allow-write" in capsys.readouterr().err
    assert main(["validate", str(network)]) == 2
    assert not (tmp_path / "escaped.nrrd").exists()


def test_a_symbolic_link_out_of_the_folder_is_outside_too(tmp_path):
    network = network_writing_to(tmp_path, "link/escaped.nrrd")
    (tmp_path / "elsewhere").mkdir()
    (network.parent / "link").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(vgraph.WritePathError):
        vgraph.load(network)


def test_allowed_folders_and_the_networks_own_folder_are_writable(tmp_path):
    inside = network_writing_to(tmp_path, "results/new/torus.nrrd")
    assert main(["run", str(inside)]) == 0
    assert (inside.parent / "results" / "new" / "torus.nrrd").is_file()  # folders made on the way

    outside = network_writing_to(tmp_path, "../out/torus.nrrd")
    assert main(["run", str(outside), "--allow-write", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "torus.nrrd").is_file()
    assert vgraph.load(outside, allow_write=[tmp_path]).get("writer.path") == "../out/torus.nrrd"


def test_paths_the_user_types_are_the_users_own(tmp_path):
    network = network_writing_to(tmp_path, "torus.nrrd")
    assert main(["run", str(network), "--set", f"writer.path={tmp_path / 'typed.nrrd'}",
                 "--port", "spline.volume", "--npy", str(tmp_path / "c.npy")]) == 0
    assert (tmp_path / "c.npy").is_file()
    main(["run", str(network), "--set", f"writer.path={tmp_path / 'typed.nrrd'}"])
    assert (tmp_path / "typed.nrrd").is_file()


@pytest.mark.parametrize("option", ["-o", "--npy", "--profile"])
@pytest.mark.parametrize("target, reason", [
    ("missing/x.out", "the folder .* does not exist"),
    (".", "folder"),
    ("/proc/vgraph-test.out", "cannot write /proc/vgraph-test.out"),
])
def test_cli_outputs_that_cannot_be_written_exit_2_naming_the_path(tmp_path, option, target, reason,
                                                                    capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(REPO / "networks" / "grayscale.json"), option, target]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "evaluated" not in err  # refused before evaluating
    assert re.search(reason, err), err


def test_a_nul_byte_in_an_output_path_is_a_named_error(tmp_path):
    with pytest.raises(vgraph.OutputFileError, match="NUL byte"):
        write_text_atomic(str(tmp_path / "a\0b.json"), "{}")


def test_a_full_disk_during_a_cli_write_is_exit_2_and_keeps_the_old_file(tmp_path, monkeypatch, capsys):
    import PIL.Image
    target = tmp_path / "image.png"
    target.write_bytes(b"the previous image")

    def disk_full(self, fp, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(PIL.Image.Image, "save", disk_full)
    assert main(["run", str(REPO / "networks" / "grayscale.json"), "-o", str(target)]) == 2
    err = capsys.readouterr().err
    assert "cannot write" in err and "No space left on device" in err
    assert target.read_bytes() == b"the previous image"
    assert [p.name for p in tmp_path.iterdir()] == ["image.png"]  # no temporary file left


def test_temporary_files_of_a_killed_writer_are_removed_by_the_next_write(tmp_path):
    target = tmp_path / "network.json"
    script = (f"import os, time\nfrom vgraph.atomic import atomic_path\n"
              f"with atomic_path({str(target)!r}) as t:\n"
              f"    t.write_text('half')\n    print(t, flush=True)\n    time.sleep(60)\n")
    writer = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    temporary = writer.stdout.readline().strip()
    assert os.path.exists(temporary)
    writer.kill()
    writer.wait()
    assert os.path.exists(temporary)  # kill -9 leaves it: nothing can run at that moment
    write_text_atomic(target, "{}")
    assert not os.path.exists(temporary) and target.read_text() == "{}"


def test_temporary_files_of_a_live_writer_are_left_alone(tmp_path):
    target = tmp_path / "volume.npy"
    with atomic_path(target) as ours:
        ours.write_bytes(b"in progress")
        with atomic_path(target) as other:  # a second write to the same target meanwhile
            np.save(other, np.zeros(2))
        assert ours.exists()
    assert target.read_bytes() == b"in progress"


def test_a_nul_byte_in_a_writer_path_from_a_file_names_the_property(tmp_path):
    network = network_writing_to(tmp_path, "a\0b.nrrd")
    with pytest.raises(vgraph.NetworkFileError, match=r"processors\[\d\]\.properties\.path: .*NUL byte"):
        vgraph.load(network)
