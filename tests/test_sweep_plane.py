"""SweepPlaneRenderer (RZSweep: Retondaro 2008; ZSweep: Farias, Mitchell and Silva 2000) against
the exact CPU reference (the reference ray caster at 16 samples per min(spacing), whose own
error is far below these bounds), the RayCaster, its threshold classification and its errors.
The PSNR bounds are those measured here less a margin (docs/explanations/sweep-plane.md)."""

from __future__ import annotations

import numpy as np
import pytest

from vgraph import VGraphError
from vgraph.camera import Camera
from vgraph.network import Network
from vgraph.numerics import reference_raycast
from vgraph.numerics.reference_boxes import RayBox
from vgraph.sweep.render import render
from vgraph.testing import GivenVolume, ray_caster_network
from vgraph.transfer_function import TransferFunction
from vgraph.volume import Volume

from helpers.sweep import EXACT_RATE, PROJECTIONS, SIZE, TF, camera, exact, psnr, smooth_volume, step_volume


def sweep_network(volume: Volume, **properties) -> Network:
    network = Network()
    network.add(GivenVolume(id="src", volume=volume))
    network.add("SweepPlaneRenderer", id="sweep", **{"transfer_function": TF, **properties})
    network.connect("src.volume", "sweep.volume")
    return network


@pytest.mark.parametrize("projection", PROJECTIONS)
def test_smooth_volume_matches_the_exact_reference(projection):
    # measured: 66.9 dB perspective, 67.2 dB orthographic; max error 0.004
    image = sweep_network(smooth_volume(), camera=camera(projection)).evaluate("sweep.image", size=SIZE)
    reference = exact(smooth_volume(), projection)
    assert psnr(image, reference) > 63.0
    assert np.abs(image - reference)[..., :3].max() < 0.01
    assert image[..., 3].min() == pytest.approx(1.0)  # over the opaque background


@pytest.mark.parametrize("projection", PROJECTIONS)
def test_step_volume_matches_the_exact_reference_within_the_averaged_models_error(projection):
    # measured: 46.1 dB perspective, 47.9 dB orthographic (the reference at rate 1: 33-34 dB);
    # the error is the step's cells, where the average of the faces differs from the trilinear field
    volume = step_volume()
    image = render(volume, camera(projection), TF, SIZE).image
    reference = exact(volume, projection)
    at_rate_1 = reference_raycast.render(volume, camera(projection), TF, SIZE)
    assert psnr(image, reference) > 43.0
    assert psnr(image, reference) > psnr(at_rate_1, reference)


def test_matches_the_raycaster_pixel_for_pixel():
    """Same camera, TF and background as the GL RayCaster (unshaded, rate 4): within the
    averaged model's error on the smooth volume."""
    volume, view = smooth_volume(), camera("perspective")
    rc = ray_caster_network(volume, view, transfer_function=TF, shading="none", sampling_rate=4.0)
    ray_cast = rc.evaluate("rc.image", size=SIZE)
    swept = sweep_network(volume, camera=view).evaluate("sweep.image", size=SIZE)
    assert psnr(swept, ray_cast) > 50.0


def test_threshold_sweeps_fewer_vertices_and_keeps_the_image_where_the_tf_is_zero_outside():
    volume = smooth_volume()
    low_free = TransferFunction(points=[(0.0, 0.0, 0.0, 0.0, 0.0), (0.5, 0.2, 0.6, 0.9, 0.0),
                                        (0.8, 0.9, 0.7, 0.2, 0.3), (1.0, 1.0, 0.3, 0.1, 0.6)])
    whole = render(volume, camera("perspective"), low_free, SIZE)
    kept = render(volume, camera("perspective"), low_free, SIZE, threshold=(0.5, 1.0))
    assert kept.vertices_swept < whole.vertices_swept / 4
    assert whole.vertices_swept == np.prod(volume.dims)
    assert kept.faces_projected < whole.faces_projected
    np.testing.assert_allclose(kept.image, whole.image, atol=1e-6)
    assert kept.image[..., :3].max() > 0.1  # something is drawn
    # Where the TF is not zero outside, the cells left out are missing from the image.
    cut = render(volume, camera("perspective"), TF, SIZE, threshold=(0.5, 1.0))
    assert np.abs(cut.image - render(volume, camera("perspective"), TF, SIZE).image).max() > 0.05


def test_threshold_through_the_processor_and_its_counts():
    network = sweep_network(smooth_volume(), camera=camera("orthographic"), threshold=[0.9, 1.0])
    network.evaluate("sweep.image", size=SIZE)
    counts = network.processors["sweep"].last_sweep
    assert 0 < counts["vertices_swept"] < 24 ** 3 / 10
    network.processors["sweep"].threshold = [0.9, 0.2]
    with pytest.raises(VGraphError, match="sweep.threshold: low 0.9 is above high 0.2"):
        network.evaluate("sweep.image", size=SIZE)


def test_depth_output_is_the_box_entry_for_an_opaque_tf():
    opaque = TransferFunction(points=[(0.0, 1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0, 1.0, 1.0)])
    volume = smooth_volume()
    view = Camera.looking_at_box((-1, -1.2, -1), (1, 1.2, 1), direction=(0.3, -0.5, -1.0),
                                 projection="orthographic")
    network = sweep_network(volume, camera=view, transfer_function=opaque)
    depth = network.evaluate("sweep.depth", size=SIZE)
    resolved = network.processors["sweep"].view_camera
    origins, directions = (a.reshape(-1, 3) for a in resolved.rays(*SIZE))
    t_in, t_out = RayBox.of([volume]).clip(origins, directions, resolved.far_distance(directions),
                                           min(volume.spacing), None)
    hit = (t_out >= t_in).reshape(SIZE[1], SIZE[0])
    assert np.array_equal(depth[..., 3] == 1.0, hit)
    np.testing.assert_allclose(depth[..., 1][hit], t_in.reshape(hit.shape)[hit], atol=1e-5)


def test_nan_voxels_are_refused_by_name():
    data = smooth_volume().data.copy()
    data[3, 4, 5] = np.nan
    volume = Volume(data, source="ripple.nrrd")
    with pytest.raises(VGraphError, match=r"SweepPlaneRenderer 'sweep'.*ripple.nrrd.*1 NaN"):
        sweep_network(volume, camera=camera("perspective")).evaluate("sweep.image", size=SIZE)


def test_a_volume_without_cells_is_refused_by_name():
    flat = Volume(np.ones((1, 8, 8), dtype=np.float32), source="slice.png")
    with pytest.raises(VGraphError, match=r"slice.png has no cells.*\(8, 8, 1\)"):
        render(flat, camera("orthographic"), TF, SIZE)
    with pytest.raises(VGraphError, match=r"SweepPlaneRenderer: size must be two positive integers "
                                          r"\(width, height\), got \(0, 4\)"):
        render(smooth_volume(), camera("orthographic"), TF, (0, 4))
    with pytest.raises(VGraphError, match=r"got \(2.5, 4\)"):  # not cut down to 2 pixels
        render(smooth_volume(), camera("orthographic"), TF, (2.5, 4))


def test_a_camera_inside_the_volume_is_refused_by_name():
    inside = Camera(position=(0.0, 0.0, 0.0), focus=(0.0, 0.0, -1.0), near=0.01, far=10.0)
    with pytest.raises(VGraphError, match="near plane cuts the volume's box"):
        render(smooth_volume(), inside, TF, SIZE)


def test_an_oriented_volume_follows_its_affine():
    """A volume whose index axes are turned against the world (Volume.direction) is swept at its
    voxels' world positions: the same agreement with the reference as on the world axes."""
    c, s = np.cos(0.5), np.sin(0.5)
    turn = ((c, 0.0, s), (0.0, 1.0, 0.0), (-s, 0.0, c))  # columns: the index axes in the world
    base = smooth_volume()
    volume = Volume(base.data, spacing=base.spacing, origin=base.origin, direction=turn)
    image = render(volume, camera("perspective"), TF, SIZE).image
    reference = reference_raycast.render(volume, camera("perspective"), TF, SIZE, sampling_rate=EXACT_RATE)
    assert psnr(image, reference) > 63.0  # measured 66.7 dB
    unturned = render(base, camera("perspective"), TF, SIZE).image
    assert np.abs(image - unturned).max() > 0.05  # the turn shows


def test_a_view_along_an_axis_ties_depths_and_still_matches():
    """Looking straight down z, every vertex of a slice has the same depth: the sweep starts from
    the whole front slice and each face is still projected once."""
    volume = smooth_volume()
    view = Camera.looking_at_box((-1, -1.2, -1), (1, 1.2, 1), direction=(0.0, 0.0, -1.0),
                                 projection="orthographic")
    result = render(volume, view, TF, SIZE)
    nx, ny, nz = volume.dims
    faces = nx * (ny - 1) * (nz - 1) + (nx - 1) * ny * (nz - 1) + (nx - 1) * (ny - 1) * nz
    assert result.faces_projected == faces
    reference = reference_raycast.render(volume, view, TF, SIZE, sampling_rate=EXACT_RATE)
    assert psnr(result.image, reference) > 63.0  # measured 67.7 dB


def test_the_threshold_keeps_a_cell_its_values_cross_with_no_vertex_inside():
    from vgraph.sweep.grid import classified_cells
    values = np.zeros((2, 2, 2))
    values[1] = 1.0  # the one cell runs from 0 to 1
    assert classified_cells(values, (0.4, 0.6)).all()
    assert not classified_cells(values, (1.5, 2.0)).any()


def test_a_transparent_transfer_function_is_named_by_the_blank_image_warning():
    from vgraph.scheduler import BlankImageWarning
    transparent = TransferFunction(points=[(0.0, 1, 1, 1, 0.0), (1.0, 1, 1, 1, 0.0)])
    network = sweep_network(smooth_volume(), camera=camera("perspective"), transfer_function=transparent)
    with pytest.warns(BlankImageWarning, match="sweep.transfer_function is transparent at every intensity"):
        image = network.evaluate("sweep.image", size=SIZE)
    assert np.all(image == [0.0, 0.0, 0.0, 1.0])


def test_a_camera_looking_away_draws_the_background():
    away = Camera(position=(0.0, 0.0, 5.0), focus=(0.0, 0.0, 10.0))  # the volume is behind it
    result = render(smooth_volume(), away, TF, SIZE, background=(0.2, 0.1, 0.0, 1.0))
    assert result.vertices_swept == 0
    assert np.all(result.image == np.float32([0.2, 0.1, 0.0, 1.0]))
