"""SliceViewer's thick slab (MIP over slab_thickness world units about the plane) against numpy:
the largest of the voxel slices the slab holds for axis-aligned planes, the largest of
map_coordinates samples one voxel step apart for an oblique plane; and pan moves the image's
centre by its part in the plane."""

import numpy as np
from scipy import ndimage

from vgraph.processors.slice_viewer import SliceViewer
from vgraph.slicing import voxel_step
from vgraph.volume import Volume

EXACT = 1e-6
TOLERANCE = 2e-5
SHAPE = (8, 7, 9)  # (z, y, x)
SPACING = (1.5, 1.5, 1.5)  # square pixels at one pixel per voxel in every orientation
OBLIQUE_SPACING = (1.5, 1.0, 2.0)


def volume(spacing=SPACING) -> Volume:
    data = np.random.default_rng(3).random(SHAPE).astype(np.float32)
    return Volume(data, spacing=spacing, origin=(3.0, -2.0, 1.0))


def slice_image(volume, size, **properties):
    viewer = SliceViewer("slice", **properties)
    viewer.render_size = tuple(size)
    return viewer.process(volume).to_numpy(), viewer


def test_an_axis_aligned_slab_is_the_maximum_of_the_voxel_slices_it_holds():
    vol = volume()
    values = vol.normalized(vol.data)
    nz, ny, nx = SHAPE
    i, j, k = 4, 3, 5
    cursor = tuple(vol.voxel_to_world((i, j, k)))
    # thickness 4 voxels along each axis: the plane's slice and 2 on either side (5 in all;
    # near the edge the slab holds fewer: k = 5 of 8 along z takes 3..7)
    expected = {"axial": ((nx, ny), 4 * SPACING[2], values[k - 2:k + 3].max(axis=0)[::-1, ::-1]),
                "coronal": ((nx, nz), 4 * SPACING[1], values[:, j - 2:j + 3].max(axis=1)[::-1, ::-1]),
                "sagittal": ((ny, nz), 4 * SPACING[0], values[..., i - 2:i + 3].max(axis=2)[::-1, ::-1])}
    for orientation, (size, thickness, mip) in expected.items():
        for interpolation in ("nearest", "linear"):
            image, _ = slice_image(vol, size, orientation=orientation, cursor=cursor,
                                   interpolation=interpolation, slab_thickness=thickness)
            np.testing.assert_allclose(image[..., 0], mip, atol=EXACT, rtol=0,
                                       err_msg=f"{orientation} {interpolation}")
    # a slab reaching past the volume takes what lies inside: z = 0 with 6 voxels each way
    edge = tuple(vol.voxel_to_world((i, j, 0)))
    image, _ = slice_image(vol, (nx, ny), orientation="axial", cursor=edge, interpolation="nearest",
                           slab_thickness=12 * SPACING[2])
    np.testing.assert_allclose(image[..., 0], values[:7].max(axis=0)[::-1, ::-1], atol=EXACT, rtol=0)


def test_a_slab_thinner_than_two_voxel_steps_is_the_plane():
    vol = volume()
    cursor = tuple(vol.voxel_to_world((4, 3, 5)))
    plain, _ = slice_image(vol, (9, 7), orientation="axial", cursor=cursor)
    thin, _ = slice_image(vol, (9, 7), orientation="axial", cursor=cursor,
                          slab_thickness=1.9 * SPACING[2])
    np.testing.assert_array_equal(thin, plain)
    thick, _ = slice_image(vol, (9, 7), orientation="axial", cursor=cursor,
                           slab_thickness=2.0 * SPACING[2])
    assert np.all(thick[..., 0] >= plain[..., 0]) and np.any(thick[..., 0] > plain[..., 0])


def test_an_oblique_slab_is_the_maximum_of_samples_one_voxel_step_apart():
    vol = volume(OBLIQUE_SPACING)
    normal = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    size, thickness = (40, 32), 7.0
    image, viewer = slice_image(vol, size, orientation="custom", normal=tuple(normal),
                                cursor=tuple(vol.voxel_to_world((4, 3, 4))), slab_thickness=thickness)
    step = voxel_step(normal, OBLIQUE_SPACING)
    half = int(np.floor(thickness / 2 / step))
    assert half >= 1
    columns, rows = np.meshgrid(np.arange(size[0]), np.arange(size[1]))
    points = viewer.pixel_to_world(columns, rows)
    data = vol.normalized(vol.data)
    dims = np.array(vol.dims)
    best = np.full(points.shape[:2], -np.inf)
    for k in range(-half, half + 1):
        voxel = vol.world_to_voxel(points + k * step * normal)
        values = ndimage.map_coordinates(data, voxel[..., ::-1].transpose(2, 0, 1), order=1, mode="nearest")
        inside = np.all((voxel >= -0.5) & (voxel <= dims - 0.5), axis=-1)
        best = np.where(inside, np.maximum(best, values), best)
    plane_inside = np.all((vol.world_to_voxel(points) >= -0.5) & (vol.world_to_voxel(points) <= dims - 0.5), axis=-1)
    expected = np.where(plane_inside, best, 0.0)
    assert plane_inside.sum() > 100
    np.testing.assert_allclose(image[..., 0], expected, atol=TOLERANCE, rtol=0)


def test_pan_moves_the_image_centre_by_its_part_in_the_plane():
    vol = volume()
    cursor = tuple(vol.voxel_to_world((4, 3, 4)))
    _, still = slice_image(vol, (32, 32), orientation="axial", cursor=cursor)
    _, panned = slice_image(vol, (32, 32), orientation="axial", cursor=cursor, pan=(2.0, -3.0, 5.0))
    # axial: the z part moves nothing, the plane stays through the cursor
    np.testing.assert_allclose(np.subtract(panned.last_plane.centre, still.last_plane.centre),
                               (2.0, -3.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(panned.last_plane.right, still.last_plane.right)
