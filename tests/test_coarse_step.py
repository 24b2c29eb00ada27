"""A drag's frame of a bricked volume drawn in one pass (FrameContext.interactive; the GUI's coarse
frames) samples at the step of the finest level it draws (vgraph.bricks.coarse_step): fewer
samples, a picture close to the still frame's, and the still frame itself unchanged bit for bit."""

import numpy as np
import pytest

from vgraph import FrameContext, Volume
from vgraph.camera import Camera
from vgraph.testing import ray_caster_network

SIZE = (56, 48)
DRAG = FrameContext(interactive=True)
TF = {"points": [[0.0, 0, 0, 0, 0], [0.3, 0.9, 0.6, 0.4, 0.0], [0.6, 1.0, 0.8, 0.6, 0.5],
                 [1.0, 1.0, 1.0, 1.0, 0.9]]}
# How far a drag's frame may be from the still frame's at the same level and size: the same medium
# sampled at the level's step instead of level 0's (opacity corrected), so what differs is where a
# steep rise falls between samples. Measured on this ball at level 2: 0.0003 on average, at most
# 0.028 (7/255), shaded or not; without the opacity correction 0.011 and 0.44, which fails both.
MEAN_TOLERANCE, MAX_TOLERANCE = 0.002, 0.06


@pytest.fixture(scope="module")
def ball() -> Volume:
    """A soft ball with a ripple on it (a smooth field, so the levels of its pyramid are close)."""
    z, y, x = np.meshgrid(*[np.linspace(-1, 1, n) for n in (64, 56, 72)], indexing="ij")
    radius = np.sqrt(x * x + 1.2 * y * y + z * z)
    field = np.clip(1.1 - radius + 0.08 * np.sin(6 * x) * np.cos(5 * z), 0, 1)
    return Volume(field.astype(np.float32))


def network(volume, compositing="dvr", **properties):
    camera = Camera.looking_at_box((0, 0, 0), (71, 55, 63), direction=(-0.5, -0.3, -1.0))
    return ray_caster_network(volume, camera, "BrickedRayCaster", compositing=compositing, brick_size=8,
                              transfer_function=TF, method="single_pass", **properties)


def frame(net, context=None):
    """The image, the samples all rays evaluated (the depth output's counter) and last_frame."""
    net.invalidate_downstream("rc")
    net.update("rc.image", "rc.depth", size=SIZE, context=context)
    depth = net.output("rc.depth").to_numpy()
    return net.output("rc.image").to_numpy(), float(depth[..., 2].sum()), dict(net["rc"].last_frame)


@pytest.mark.parametrize("shading", ["none", "blinn_phong"])
def test_a_drags_frame_takes_its_levels_samples_and_stays_close_to_the_still_frame(ball, shading):
    net = network(ball, finest_level=2, lod_bias=-16.0, shading=shading)  # every brick at level 2
    still, still_samples, still_frame = frame(net)
    drag, drag_samples, drag_frame = frame(net, DRAG)
    assert still_frame["levels"] == drag_frame["levels"] == [2]
    assert still_frame["sample_stride"] == 1 and drag_frame["sample_stride"] == 4  # 2^2 level-0 steps
    # the levels' error bound is of level-0 steps: a drag's frame claims none
    assert still_frame["error_bound"] is not None and drag_frame["error_bound"] is None
    assert "a sample every 4 level-0 steps (dragging)" in net["rc"].frame_summary()
    # a still dvr frame steps each level's lattice itself (PAGED_STRIDE, vgraph.bricks.paged_strides),
    # so the drag's frame takes as many samples (measured 9474 against 10278; level 0's lattice in
    # these bricks would be about 4 times the still frame's: mip's test below)
    assert abs(drag_samples - still_samples) <= 0.1 * still_samples
    difference = np.abs(drag - still)
    assert difference.mean() <= MEAN_TOLERANCE and difference.max() <= MAX_TOLERANCE
    assert drag[..., 3].max() > 0.5  # the ball is there, not a blank frame


def test_a_drags_mip_frame_takes_a_quarter_of_the_still_frames_samples(ball):
    """mip (and iso) still frames take every sample of level 0's lattice in coarse bricks too; a
    drag's frame takes its level's."""
    net = network(ball, compositing="mip", finest_level=2, lod_bias=-16.0)
    still, still_samples, _ = frame(net)
    drag, drag_samples, drag_frame = frame(net, DRAG)
    assert drag_frame["levels"] == [2] and drag_frame["sample_stride"] == 4
    assert drag_samples <= still_samples / 3  # about a quarter (a ray's first sample is taken by both)
    assert np.abs(drag - still).max() <= MAX_TOLERANCE and drag[..., 3].max() > 0.5


def test_the_still_frame_is_unchanged_bit_for_bit(ball):
    """The frame after the release is the frame a network never dragged draws; at level 0 a drag's
    frame is the still frame itself (stride 1)."""
    never_dragged, _, _ = frame(network(ball, finest_level=1, lod_bias=-16.0))
    net = network(ball, finest_level=1, lod_bias=-16.0)
    frame(net)
    dragged, _, drag_frame = frame(net, DRAG)
    released, _, released_frame = frame(net)
    assert drag_frame["sample_stride"] == 2 and not np.array_equal(dragged, released)
    assert released_frame["sample_stride"] == 1 and np.array_equal(released, never_dragged)

    level0 = network(ball, lod_bias=-16.0)
    still, _, _ = frame(level0)
    drag, _, drag_frame = frame(level0, DRAG)
    assert drag_frame["levels"] == [0] and drag_frame["sample_stride"] == 1 and np.array_equal(drag, still)


def test_the_render_process_draws_a_drags_frame_at_its_levels_step(ball):
    """A job below full scale (the GUI's while the mouse moves) gives the caster ``interactive``;
    the refined job after the release does not."""
    from vgraph.live.render_messages import RenderJob
    from vgraph.live.render_server import RenderServer

    server = RenderServer()
    server.network = network(ball, finest_level=2, lod_bias=-16.0)
    server.network.add("Canvas", id="canvas", size=list(SIZE))
    server.network.connect("rc.image", "canvas.image")
    caster = server.network["rc"]
    dragged = server.handle(RenderJob(1, None, scale=0.5))
    assert dragged.error is None and caster.evaluated_context.interactive
    assert caster.last_frame["sample_stride"] == 4
    released = server.handle(RenderJob(2, None, scale=1.0))
    assert released.error is None and not caster.evaluated_context.interactive
    assert caster.last_frame["sample_stride"] == 1


def test_the_raycaster_drawing_a_store_over_its_budget_takes_the_drags_step_too(tmp_path):
    """The RayCaster's hand-over to the bricks (a store over its memory budget) is given the
    context's ``interactive`` as the BrickedRayCaster is."""
    from vgraph.bricks.volume import BrickedVolume
    from vgraph.io.convert import convert

    z, y, x = np.mgrid[-1:1:96j, -1:1:80j, -1:1:112j]
    np.save(tmp_path / "ball.npy", (np.clip(1.0 - np.sqrt(x * x + y * y + z * z), 0, 1) * 65535).astype(np.uint16))
    convert(tmp_path / "ball.npy", tmp_path / "ball.zarr", brick=16, progress=False)
    camera = Camera.looking_at_box((0, 0, 0), (111, 79, 95), direction=(-0.5, -0.3, -1.0))
    store = BrickedVolume.open(tmp_path / "ball.zarr", memory_budget_mb=1.0)  # 1.7 MB: over it
    net = ray_caster_network(store, camera, "RayCaster", compositing="dvr",
                             transfer_function=TF, lod_bias=1.0, ram_budget=1.0, gl_budget=1.0)
    still, _, still_frame = frame(net)
    drag, _, drag_frame = frame(net, DRAG)
    level = min(drag_frame["levels"])
    assert net["rc"].frame_summary().startswith("single pass") and level >= 1 and still_frame["levels"] == drag_frame["levels"]
    assert still_frame["sample_stride"] == 1 and drag_frame["sample_stride"] == 2 ** level
    assert np.abs(drag - still).mean() <= MEAN_TOLERANCE
