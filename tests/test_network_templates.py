"""Shipped networks as templates (issue 28, defect 4): a network from networks/ applied to another
file with `--set source.path=` frames the new data (its cameras fit the data instead of carrying
a pose made for the file it shipped with), recomputes the automatic windows, and keeps its
stored poses only where its description says why."""

from __future__ import annotations

import json
import warnings

import meshio
import numpy as np
import pytest

import vgraph
from vgraph.cli_values import set_from_command_line
from vgraph.io import read_volume, write_volume
from vgraph.scheduler import default_target
from vgraph.volume import Volume

from helpers.paths import REPO

NETWORKS = sorted((REPO / "networks").glob("*.json"))
SIZE = (96, 80)
# What else a network needs on data that is not the one it shipped with: the head's skin is cut at
# x = 100 mm of that head, the hydrogen channel is placed one voxel in (its raw settings are
# ignored, with a warning, for a file with a header).
EXTRA = {"head_skin_mesh_bone_volume": ["skin.region_max=null"],
         "two_channels_hydrogen_neghip": ["hydrogen.origin=null"],
         "tets_lox_post": ["source.array="], "tets_disk_out_ref": ["source.array="]}
PORT = {"mpr_mri_head": "rc.image",  # its first canvas is the axial slice; the 3D view frames
        "depth_cues_head": "rc.image"}  # its depth cues darken a halo outside the box on purpose


def cameras(document: dict) -> list[dict]:
    return [p["properties"]["camera"] for p in document["processors"] if "camera" in p["properties"]]


def fitting_templates() -> list[str]:
    """The shipped networks that read a file and whose cameras all fit the data."""
    names = []
    for path in NETWORKS:
        document = json.loads(path.read_text())
        reads = any(p["type"] in ("VolumeSource", "MeshSource") for p in document["processors"])
        if reads and cameras(document) and all(c.get("fit_to_data") for c in cameras(document)):
            names.append(path.stem)
    return names


@pytest.fixture(scope="module")
def elsewhere(tmp_path_factory):
    """A volume, a label volume and a mesh of another size, spacing and place than any shipped
    network's data (values 0 .. 3000, so data-unit transfer functions see them too)."""
    folder = tmp_path_factory.mktemp("elsewhere")
    dims = (40, 28, 20)
    z, y, x = np.meshgrid(*(np.linspace(-1.0, 1.0, n) for n in dims[::-1]), indexing="ij")
    r = np.sqrt(x * x + y * y + z * z)
    grid = {"spacing": (2.5, 1.5, 3.0), "origin": (300.0, -500.0, 80.0)}
    write_volume(Volume(np.clip(3000 * (1.1 - r), 0, 3000).astype(np.uint16), **grid), folder / "blob.nrrd")
    labels = np.where(r < 0.5, 2, np.where(r < 0.9, 1, 0)).astype(np.uint8)
    write_volume(Volume(labels, **grid), folder / "labels.nrrd")
    axis = np.linspace(0.0, 1.0, 4)
    points = np.stack(np.meshgrid(axis * 30 + 200, axis * 10 - 40, axis * 50, indexing="ij"), -1).reshape(-1, 3)
    index = lambda i, j, k: (i * 4 + j) * 4 + k  # noqa: E731
    hexes = np.array([[index(i + a, j + b, k + c) for c in (0, 1) for a, b in ((0, 0), (1, 0), (1, 1), (0, 1))]
                      for i in range(3) for j in range(3) for k in range(3)])
    meshio.write(folder / "part.vtu", meshio.Mesh(points, [("hexahedron", hexes)],
                                                  point_data={"T": (points ** 2).sum(axis=1)}))
    return folder


def applied(name: str, folder) -> tuple[vgraph.Network, str, np.ndarray, np.ndarray]:
    """(the network on the other data, its target, the data's world box corners (8, 3), the
    image)."""
    network = vgraph.load(REPO / "networks" / f"{name}.json")
    sources = [p for p in network.processors.values() if p.type_name in ("VolumeSource", "MeshSource")]
    if sources[0].type_name == "MeshSource":
        data = folder / "part.vtu"
        low, high = meshio.read(data).points.min(axis=0), meshio.read(data).points.max(axis=0)
    else:
        data = folder / ("labels.nrrd" if name.startswith("labels") else "blob.nrrd")
        low, high = read_volume(data).world_box()
    for source in sources:
        set_from_command_line(network, f"{source.id}.path={data}")
    for assignment in EXTRA.get(name, []):
        set_from_command_line(network, assignment)
    target = PORT.get(name) or default_target(network)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vgraph.VGraphWarning)
        image = np.asarray(network.evaluate(target, size=SIZE))
    corners = np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])])
    return network, target, corners, image


def test_the_shipped_examples_frame_their_data_unless_their_description_says_why_not():
    names = fitting_templates()
    assert {"raycast_head", "mip_engine", "labels_engine", "head_skin_mesh_bone_volume", "mpr_mri_head",
            "tets_bonsai", "tets_lox_post", "tets_disk_out_ref", "two_channels_hydrogen_neghip"} <= set(names)
    for path in NETWORKS:
        document = json.loads(path.read_text())
        if cameras(document) and not all(c.get("fit_to_data") for c in cameras(document)):
            assert "stored pose" in document["description"], path.stem


@pytest.mark.parametrize("name", fitting_templates())
def test_a_shipped_network_on_other_data_frames_it(name, elsewhere):
    network, target, corners, image = applied(name, elsewhere)
    renderer = network[target.partition(".")[0]] if name in PORT else None
    if renderer is None:  # the processor that draws the canvas's image
        canvas = next(c for c in network.connections if c.target == target.partition(".")[0])
        renderer = network[canvas.source]
        while getattr(renderer, "view_camera", None) is None:  # an ImageCompositor: its front
            renderer = network[next(c.source for c in network.connections if c.target == renderer.id)]
    camera = renderer.view_camera
    clip = np.c_[corners, np.ones(8)] @ camera.view_projection(SIZE[0] / SIZE[1]).T
    ndc = clip[:, :2] / clip[:, 3:]
    assert np.all(clip[:, 3] > 0) and np.all(np.abs(ndc) <= 1.0 + 1e-9), f"the data's box leaves the view: {ndc}"
    background = np.asarray(getattr(renderer, "background", None) or (0.0, 0.0, 0.0, 0.0))[:3]
    drawn = np.abs(image[..., :3] - background).max(axis=-1) > 0.02  # depth_cues_head's is white
    assert drawn.mean() > 0.02, "the data does not show"
    rows, cols = np.nonzero(drawn)
    # Every drawn pixel lies within the projected box (plus a pixel), which lies in the image.
    pixel_x = (ndc[:, 0] + 1) / 2 * SIZE[0]
    pixel_y = (1 - ndc[:, 1]) / 2 * SIZE[1]
    assert cols.min() >= pixel_x.min() - 1 and cols.max() <= pixel_x.max() + 1
    assert rows.min() >= pixel_y.min() - 1 and rows.max() <= pixel_y.max() + 1


def test_the_mpr_slices_take_their_window_from_the_new_data(elsewhere):
    """networks/mpr_mri_head.json had a fixed window (220, 440) for its MRI: on a CT-like volume
    of values up to 3000 the slice was white. Now the source's robust window sets it."""
    network = vgraph.load(REPO / "networks" / "mpr_mri_head.json")
    assert all(network[v].window is None for v in ("axial", "coronal", "sagittal"))
    set_from_command_line(network, f"source.path={elsewhere / 'blob.nrrd'}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vgraph.VGraphWarning)
        slice_ = np.asarray(network.evaluate("axial.image", size=(64, 64)))[..., 0]
    inside = slice_[slice_ > 0.02]
    assert inside.size > 0.1 * slice_.size and np.mean(inside > 0.99) < 0.05  # greys, not saturated
    assert inside.max() > 0.8  # the bright centre reaches the top of the window


def test_raw_settings_are_ignored_with_a_warning_for_a_file_with_a_header(elsewhere):
    """A network made for a headerless raw file, given an NRRD: its raw_dims would read the NRRD
    as raw bytes ('truncated'); the header wins and a warning names the setting."""
    network = vgraph.Network()
    network.add("VolumeSource", id="source", raw_dims=[64, 64, 64], raw_dtype="float32")
    network.set("source.path", str(elsewhere / "blob.nrrd"))
    with pytest.warns(vgraph.VGraphWarning, match=r"source\.raw_dims is ignored: blob\.nrrd has a header"):
        volume = network.evaluate("source.volume")
    assert volume.shape == (20, 28, 40)
