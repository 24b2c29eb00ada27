"""What a user installs: the wheel holds processors and shaders; a plug-in package installed with
pip is found through its entry point; a module given with --plugin is loaded."""

import json
import os
import re
import shutil
import subprocess
import sys
import zipfile

import numpy as np
import PIL.Image
import pytest

from helpers.paths import REPO

WHEEL_IMAGE = REPO / "networks" / "data" / "color_wheel.png"


def pip(*args, cwd=None):
    done = subprocess.run([sys.executable, "-m", "pip", "--disable-pip-version-check", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    return done


def test_wheel_contains_processors_and_shaders(tmp_path):
    source = tmp_path / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, source / name)
    for folder in ("src", "processors", "shaders", "docs"):
        shutil.copytree(REPO / folder, source / folder, ignore=shutil.ignore_patterns("__pycache__"))
    pip("wheel", "--no-deps", "--no-build-isolation", "-w", tmp_path / "dist", source)
    wheel, = (tmp_path / "dist").glob("vgraph-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for processor in (REPO / "processors").glob("*.py"):
        assert f"vgraph/processors/{processor.name}" in names
    for module in (REPO / "src" / "vgraph").rglob("*.py"):
        assert f"vgraph/{module.relative_to(REPO / 'src' / 'vgraph').as_posix()}" in names, module
    for shader in (REPO / "shaders").rglob("*.glsl"):
        assert f"vgraph/shaders/{shader.relative_to(REPO / 'shaders').as_posix()}" in names
    for page in (REPO / "docs").rglob("*.md"):   # Help > Documentation reads them offline
        assert f"vgraph/docs/{page.relative_to(REPO / 'docs').as_posix()}" in names, page
    assert any(n.endswith("entry_points.txt") for n in names)
    assert_pictures_installed(wheel, tmp_path / "site")


def assert_pictures_installed(wheel, site):
    """The pages' pictures ship beside them (a few MB), and from where the wheel installs them
    every image link of every page names a file (Help shows them through help.image_path)."""
    from vgraph.gui.help import image_path
    pictures = [info for info in zipfile.ZipFile(wheel).infolist() if info.filename.startswith("vgraph/docs/images/")]
    assert pictures and sum(info.file_size for info in pictures) < 15e6
    zipfile.ZipFile(wheel).extractall(site)
    pages = list((site / "vgraph" / "docs").rglob("*.md"))   # the processor reference's too
    links = [(page, link) for page in pages
             for link in re.findall(r"!\[[^\]]*\]\(([^)\s]+)\)", page.read_text(encoding="utf-8"))]
    assert links
    for page, link in links:
        assert image_path(page, link) == page.parent / link, (page.name, link)


def plugin_network(tmp_path, invert_alpha=False):
    document = {
        "format": "vgraph-network", "version": 1,
        "processors": [
            {"id": "source", "type": "ImageSource", "properties": {"path": str(WHEEL_IMAGE)}},
            {"id": "invert", "type": "Invert", "properties": {"invert_alpha": invert_alpha}},
            {"id": "canvas", "type": "Canvas",  # the picture's size: shown as it is, not resampled
             "properties": {"size": list(PIL.Image.open(WHEEL_IMAGE).size)}}],
        "connections": [{"from": "source.image", "to": "invert.image"},
                        {"from": "invert.image", "to": "canvas.image"}]}
    path = tmp_path / "invert.json"
    path.write_text(json.dumps(document))
    return path


def run_vgraph(args, pythonpath):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(map(str, pythonpath)))
    return subprocess.run([sys.executable, "-m", "vgraph", *map(str, args)], capture_output=True,
                          text=True, env=env, timeout=300)


def test_installed_plugin_is_found_through_its_entry_point(tmp_path):
    target = tmp_path / "site"
    pip("install", "--no-deps", "--no-build-isolation", "--target", target, REPO / "tests" / "plugin_example")
    done = run_vgraph(["run", plugin_network(tmp_path), "--npy", tmp_path / "out.npy"], [target])
    assert done.returncode == 0, done.stderr
    original = np.asarray(PIL.Image.open(WHEEL_IMAGE).convert("RGBA")).astype(np.float32) / 255
    result = np.load(tmp_path / "out.npy")
    np.testing.assert_allclose(result[..., :3], 1 - original[..., :3], atol=1e-6)
    np.testing.assert_allclose(result[..., 3], original[..., 3])
    listing = run_vgraph(["list", "--json"], [target])
    invert = next(e for e in json.loads(listing.stdout) if e["type"] == "Invert")
    assert invert["properties"][0]["name"] == "invert_alpha"


def test_without_the_plugin_the_error_names_types_and_plugins(tmp_path):
    done = run_vgraph(["validate", plugin_network(tmp_path)], [])
    assert done.returncode == 2
    assert "processors[1].type: unknown processor type 'Invert'" in done.stderr
    assert "plug-ins loaded: none" in done.stderr


def test_plugin_option_loads_a_module_by_name(tmp_path):
    done = run_vgraph(["run", "--plugin", "vgraph_invert", plugin_network(tmp_path, True),
                       "--npy", tmp_path / "out.npy"], [REPO / "tests" / "plugin_example"])
    assert done.returncode == 0, done.stderr
    assert np.load(tmp_path / "out.npy")[..., 3].max() == pytest.approx(0.0)


def test_a_broken_plugin_is_reported_and_the_rest_still_loads(tmp_path):
    package = tmp_path / "site" / "broken_plugin-1.0.dist-info"
    package.mkdir(parents=True)
    (package / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-plugin\nVersion: 1.0\n")
    (package / "entry_points.txt").write_text("[vgraph.processors]\nbroken = no_such_module_anywhere\n")
    listing = run_vgraph(["list"], [tmp_path / "site"])
    assert listing.returncode == 0 and "Grayscale" in listing.stdout
    assert "broken (no_such_module_anywhere) failed to load: ModuleNotFoundError" in listing.stderr
    done = run_vgraph(["validate", plugin_network(tmp_path)], [tmp_path / "site"])
    assert done.returncode == 2 and "broken (no_such_module_anywhere) failed to load" in done.stderr
