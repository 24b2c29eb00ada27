"""`vgraph bench accuracy`'s sections for the other renderers (vgraph.accuracy_sections): the
tetrahedra and bricked sections at a tiny size on the cases made without data, their tables holding
the PSNR and max error this test recomputes for a row against the reference, their plots, and the
refusals (a missing data file, an unknown section) before any measuring. No timing assertions."""

import math

import numpy as np
import PIL.Image

from vgraph import accuracy_bricks, accuracy_tetra
from vgraph.cli import main
from vgraph.mesh_shapes import c_shape
from vgraph.numerics import reference_tetra
from vgraph.processors.projected_tetrahedra import ProjectedTetrahedra
from vgraph.testing import ray_caster_network

SIZE = (32, 32)
FINEST = -16.0  # lod_bias that keeps every brick at level 0 (tests/test_bricked_raycaster.py)


def table(path):
    """The rows of a markdown table as lists of cells (header and separator left out)."""
    rows = [line.strip("|").split("|") for line in path.read_text().splitlines() if line.startswith("| ")]
    return [[cell.strip() for cell in row] for row in rows[1:]]


def psnr_and_max(image, reference):
    difference = np.asarray(image, np.float64)[..., :3] - np.asarray(reference, np.float64)[..., :3]
    mse = np.mean(difference ** 2)
    return (math.inf if mse == 0 else 10 * math.log10(1 / mse)), float(np.abs(difference).max())


def assert_plot(path):
    with PIL.Image.open(path) as image:
        assert image.format == "PNG" and image.size[0] > 200


def test_tetrahedra_section_writes_the_errors_against_the_exact_reference(tmp_path, capsys):
    out = tmp_path / "acc"
    code = main(["bench", "accuracy", "--renderers", "tetrahedra", "--meshes", "grid", "c",
                 "--integrations", "partial", "averaged", "--orders", "mpvonc", "--size", "32x32",
                 "--repeat", "1", "--out", str(out)])
    assert code == 0
    text = (out / "tetrahedra.md").read_text()
    assert "32 x 32 pixels, best of 1 frames" in text and "GL renderer" in text
    rows = table(out / "tetrahedra.md")
    assert [(r[0], r[2], r[3], r[4]) for r in rows] == [
        (mesh, tf, integration, "mpvonc") for mesh in ("6^3 grid, 0..100", "C (non-convex)")
        for tf in ("ramp", "spike") for integration in ("partial", "averaged")]
    assert all(float(r[7]) >= 0 for r in rows)
    # Recomputed: the C under the spike, partial pre-integration, mpvonc.
    mesh = c_shape()
    camera = accuracy_tetra.c_camera(mesh)
    tf = accuracy_tetra.transfer_functions(mesh)["spike"]
    processor = ProjectedTetrahedra(camera=camera, transfer_function=tf, integration="partial",
                                    visibility_order="mpvonc")
    processor.render_size = SIZE
    image = processor.process(mesh)["image"].to_numpy()
    db, worst = psnr_and_max(image, reference_tetra.render(mesh, camera, tf, SIZE))
    row = next(r for r in rows if r[0] == "C (non-convex)" and r[2] == "spike" and r[3] == "partial")
    assert row[1] == "675"
    assert abs(float(row[5]) - db) <= 0.05 + 1e-9 and float(row[6]) == float(f"{worst:.2g}")
    assert db > 90  # partial with mpvonc on the non-convex C: the section measures a good renderer
    assert_plot(out / "tetrahedra.png")
    assert capsys.readouterr().out.startswith("# ProjectedTetrahedra: error against frame time")


def test_bricked_section_writes_the_errors_against_the_level_0_frame(tmp_path):
    out = tmp_path / "acc"
    code = main(["bench", "accuracy", "--renderers", "bricked", "--volumes", "synthetic", "--brick", "16",
                 "--size", "32x32", "--repeat", "1", "--out", str(out)])
    assert code == 0
    text = (out / "bricked.md").read_text()
    assert "32 x 32 pixels, 16^3 bricks" in text and "median of 1 interleaved frames" in text
    rows = table(out / "bricked.md")
    labels = ["level 0", "level 1", "level 2"] + [f"lod_bias 15, max_error {b:g}" for b in accuracy_bricks.BUDGETS]
    assert [(r[1], r[2]) for r in rows] == [(tf, label) for tf in ("smooth", "stiff", "faint") for label in labels]
    assert {r[8] for r in rows if r[2] == "level 0"} == {"[0]"}  # every brick at level 0, forced
    assert {r[8] for r in rows if r[2] == "level 2"} == {"[2]"}
    # Recomputed: the stiff TF, the coarsest level asked for with no budget, against level 0.
    volume = accuracy_bricks.synthetic_volume()
    camera = accuracy_bricks.camera_for(volume)
    images = [np.asarray(ray_caster_network(volume, camera, "BrickedRayCaster", lod_bias=bias, max_error=1.0,
                                            transfer_function=accuracy_bricks.STIFF, brick_size=16,
                                            **accuracy_bricks.COMMON).evaluate("rc.image", size=SIZE))
              for bias in (15.0, FINEST)]
    db, worst = psnr_and_max(*images)
    row = next(r for r in rows if r[1] == "stiff" and r[2] == "lod_bias 15, max_error 1")
    assert abs(float(row[5]) - db) <= 0.05 + 1e-9 and float(row[6]) == float(f"{worst:.3g}")
    assert worst > 0.5  # a coarse level under a spike: the error the budget exists for
    assert_plot(out / "bricked.png")


def test_a_missing_data_file_is_named_before_any_section_measures(tmp_path, capsys):
    out = tmp_path / "acc"
    files = {"--post-mesh": tmp_path / "post.vtk", "--disk-mesh": tmp_path / "disk.vtu",
             "--bonsai": tmp_path / "bonsai.nii.gz"}
    for path in files.values():
        path.write_bytes(b"")  # present: only the one left out below is missing
    for option, present in files.items():
        missing = tmp_path / "missing" / present.name
        given = [part for key, path in files.items() for part in (key, str(missing if key == option else path))]
        # All sections (curvature first): the missing file stops the command before any measuring.
        code = main(["bench", "accuracy", "--quick", "--meshes", "post", "disk", "grid", "--volumes", "bonsai",
                     *given, "--out", str(out)])
        assert code == 2
        error = capsys.readouterr().err.strip()
        assert len(error.splitlines()) == 1 and "Traceback" not in error
        assert str(missing) in error and option in error and "not found" in error
        assert not out.exists() or not any(out.iterdir())


def test_unknown_sections_and_names_are_refused(tmp_path, capsys):
    for args, named in ((["--renderers", "volume"], "'volume'"), (["--meshes", "cube"], "'cube'"),
                        (["--orders", "kbuffer"], "'kbuffer'"), (["--volumes", "head"], "'head'"),
                        (["--brick", "4"], "4")):
        assert main(["bench", "accuracy", "--quick", *args, "--out", str(tmp_path / "x")]) == 2
        error = capsys.readouterr().err
        assert args[0] in error and named in error
