"""What the tests of empty-space skipping and of the walk grids share (tests/test_mip_skipping.py,
test_paged_walk.py, test_paged_iso_grid.py, the refining tests): the pictures' size, a noise
volume, the cameras every case is drawn from, the comparison of two pictures bit for bit, and a
brick's blocks' ranges as the atlas records them."""

import numpy as np

from vgraph.camera import Camera
from vgraph.numerics.reference_raycast import volume_box
from vgraph.volume import Volume

SIZE = (64, 48)


def noise(shape=(37, 29, 41), seed=5):
    return Volume(np.random.default_rng(seed).random(shape).astype(np.float32), spacing=(1.0, 0.9, 1.2))


def cameras(volume):
    lo, hi = volume_box(volume)
    centre = (lo + hi) / 2
    inside = Camera(position=tuple(centre + 0.3 * (hi - lo) * np.array([0.2, -0.3, 0.4])),
                    focus=tuple(centre + (hi - lo) * np.array([0.5, 0.2, -0.3])),
                    near=0.01 * float(np.max(hi - lo)), far=10.0 * float(np.max(hi - lo)), fov=70)
    return {"perspective": Camera.looking_at_box(lo, hi, direction=(-0.5, -0.3, -1.0)),
            "orthographic": Camera.looking_at_box(lo, hi, direction=(0.3, -0.6, -1.0),
                                                  projection="orthographic"),
            "inside": inside}


def assert_same_picture(skipped, plain):
    (image, depth), (plain_image, plain_depth) = skipped, plain
    np.testing.assert_array_equal(image, plain_image)
    # depth: window depth, distance, (b = samples evaluated, differs), has a depth sample
    np.testing.assert_array_equal(depth[..., [0, 1, 3]], plain_depth[..., [0, 1, 3]])


def block_ranges(source, key, fmt):
    """A brick's blocks' ranges as the atlas records them, padded to a slot of the largest brick's blocks."""
    from vgraph.bricks.cache import block_ranges_of, read_with_halo, to_texture_values
    ranges = block_ranges_of(to_texture_values(read_with_halo(source, key), fmt, source.value_range), fmt)
    out = np.full((2, 2, 2, 2), np.nan, dtype=np.float32)  # blocks of 8 in a slot of 16 (or 12) voxels
    out[:ranges.shape[0], :ranges.shape[1], :ranges.shape[2]] = ranges
    return out
