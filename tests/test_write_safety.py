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


# --- validate refuses what run refuses; confinement checked again as the writer writes ----------------
def image_writer_network(tmp_path, path: str):
    """raycast_sphere.json in tmp_path/received with an ImageWriter of ``path`` on the ray caster."""
    document = json.loads((REPO / "networks" / "raycast_sphere.json").read_text())
    document["processors"].append({"id": "w", "type": "ImageWriter", "properties": {"path": path}})
    document["connections"].append({"from": "rc.image", "to": "w.image"})
    folder = tmp_path / "received"
    (folder / "a folder").mkdir(parents=True, exist_ok=True)
    (folder / "net.json").write_text(json.dumps(document))
    return folder / "net.json"


@pytest.mark.parametrize("make, path, reason", [
    (image_writer_network, ".", "names a folder, not a file ending in .png"),
    (image_writer_network, "", "no output file chosen"),
    (image_writer_network, "x.json", "the name must end in .png"),
    (image_writer_network, "a folder", "names a folder"),
    (image_writer_network, "net.json/x.png", "net.json' is not a folder"),
    (network_writing_to, ".", "names a folder, not a file ending in .npy or .npz or .nrrd or .nii or .nii.gz"),
    (network_writing_to, "", "no output file chosen"),
    (network_writing_to, "x.json", "the name must end in .npy or .npz"),
])
def test_validate_refuses_the_writer_paths_run_refuses_with_the_same_message(tmp_path, capsys, make, path,
                                                                             reason):
    network = make(tmp_path, path)
    messages = []
    for command in ("validate", "run"):
        assert main([command, str(network)]) == 2
        err = capsys.readouterr().err
        assert "evaluated" not in err and "Traceback" not in err  # run refuses before evaluating
        assert re.search(r"net\.json: processors\[\d\]\.properties\.path: \w+ \((Image|Volume)Writer\) ",
                         err), err
        assert reason in err, err
        messages.append(err)
    assert messages[0] == messages[1]


def test_a_path_typed_with_set_replaces_a_bad_one_from_the_file(tmp_path, capsys):
    network = image_writer_network(tmp_path, "x.json")
    assert main(["run", str(network), "--set", f"w.path={tmp_path / 'typed.png'}",
                 "--set", "canvas.size=[16, 16]"]) == 0
    assert (tmp_path / "typed.png").is_file()


@pytest.mark.parametrize("make, name", [(network_writing_to, "torus.nrrd"), (image_writer_network, "w.png")])
def test_a_folder_turned_into_a_link_after_loading_is_not_followed_when_writing(tmp_path, make, name):
    """A GUI left open for hours: the folder the writer writes into becomes a symbolic link to
    somewhere else after the network was loaded (and checked)."""
    network_file = make(tmp_path, f"results/{name}")
    network = vgraph.load(network_file)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (network_file.parent / "results").symlink_to(elsewhere)
    with pytest.raises(vgraph.ProcessorError, match=r"its folder resolves to .*elsewhere, outside the "
                                                     r"folders this network may write into") as refused:
        network.evaluate("w" if name == "w.png" else "writer", size=(16, 16))
    assert not refused.value.internal
    assert list(elsewhere.iterdir()) == []


def test_a_link_made_on_the_way_to_a_folder_the_writer_creates_is_not_followed(tmp_path):
    network_file = network_writing_to(tmp_path, "a/b/torus.nrrd")
    network = vgraph.load(network_file)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (network_file.parent / "a").symlink_to(elsewhere)
    with pytest.raises(vgraph.ProcessorError, match="outside the folders this network may write into"):
        network.evaluate("writer")
    assert list(elsewhere.iterdir()) == []  # not even the folder b


def test_a_target_turned_into_a_link_pointing_outside_is_not_replaced_and_its_file_is_untouched(tmp_path):
    network_file = network_writing_to(tmp_path, "torus.nrrd")
    network = vgraph.load(network_file)
    victim = tmp_path / "notes.nrrd"
    victim.write_bytes(b"the user's own file")
    (network_file.parent / "torus.nrrd").symlink_to(victim)
    with pytest.raises(vgraph.ProcessorError, match="outside the folders this network may write into"):
        network.evaluate("writer")
    assert victim.read_bytes() == b"the user's own file"
    assert (network_file.parent / "torus.nrrd").is_symlink()


def test_a_path_a_script_sets_after_loading_is_the_scripts_own(tmp_path):
    network = vgraph.load(network_writing_to(tmp_path, "torus.nrrd"))
    network.set("writer.path", str(tmp_path / "chosen" / "torus.nrrd"))
    network.evaluate("writer")
    assert (tmp_path / "chosen" / "torus.nrrd").is_file()


def test_links_inside_the_networks_folder_are_followed_as_before(tmp_path):
    network_file = network_writing_to(tmp_path, "results/torus.nrrd")
    network = vgraph.load(network_file)
    (network_file.parent / "kept").mkdir()
    (network_file.parent / "results").symlink_to(network_file.parent / "kept")
    network.evaluate("writer")
    assert (network_file.parent / "kept" / "torus.nrrd").is_file()


def test_a_temporary_name_taken_by_a_planted_link_is_passed_over(tmp_path, monkeypatch):
    """The temporary file is created with O_EXCL | O_NOFOLLOW: a link planted under the name it
    would take is neither followed nor replaced; another name is taken."""
    import secrets
    names = iter(["planted0", "planted0", "free0000"])
    monkeypatch.setattr(secrets, "token_hex", lambda n: next(names))
    victim = tmp_path / "victim.txt"
    victim.write_text("untouched")
    target = tmp_path / "out.json"
    (tmp_path / f".out.json.{os.getpid()}.planted0.tmp.json").symlink_to(victim)
    write_text_atomic(target, "{}")
    assert target.read_text() == "{}" and victim.read_text() == "untouched"


def test_a_name_as_long_as_the_system_allows_is_written_with_a_shorter_temporary_name(tmp_path):
    target = tmp_path / ("n" * 251 + ".png")
    write_text_atomic(target, "x")
    assert target.read_text() == "x" and sorted(tmp_path.iterdir()) == [target]


def test_the_gui_render_process_checks_the_write_confinement_as_its_writers_write(tmp_path):
    """A GUI left open for hours: the window's network was checked when opened, the render
    process writes; a link made in between is refused there too."""
    from vgraph.fileformat import network_document
    from vgraph.live.render_messages import RenderJob
    from vgraph.live.render_server import RenderServer
    network_file = network_writing_to(tmp_path, "results/torus.nrrd")
    network = vgraph.load(network_file)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (network_file.parent / "results").symlink_to(elsewhere)
    result = RenderServer().handle(RenderJob(1, network_document(network), str(network.base_dir),
                                             include_writers=True,
                                             write_confinement=network.write_confinement))
    assert "outside the folders this network may write into" in result.outcome.failed["writer"], result
    assert list(elsewhere.iterdir()) == []
