"""VolumeMorphology: dilate, erode, open or close a volume with a ball whose radius is in world units.

Conventions:
- The ball of ``radius`` world units is an ellipsoid of voxels on an anisotropic grid
  (vgraph.volume_segmentation.ball_offsets): radius 4.8 on spacing 3.2 x 3.2 x 1.5 reaches 1 voxel
  along x and y and 3 along z.
- Intensities: grey-value morphology (scipy.ndimage.grey_dilation / grey_erosion with the ball
  as footprint): dilate = the largest value in the ball, erode = the smallest, open = erode then
  dilate, close = dilate then erode. The type, value range and grid are the input's.
- Labels and masks (a volume flagged as labels): each label is a set of voxels. Dilation grows
  the labels into the background (0): a background voxel takes the largest label in its ball
  (labelled voxels keep theirs); erosion keeps a label where the whole ball holds it, else 0. On
  a mask (0 / 1) these are scipy.ndimage.binary_dilation and binary_erosion.
- Beyond the volume's faces the voxels are mirrored (scipy's 'reflect'), for masks too: an object
  touching a face is not eroded from the face (scipy's binary_erosion, border 0, would).
- NaN and Inf are replaced by the value range's ends first, with a warning (a NaN has no order).
- A radius of 0, or a ball reaching further than the volume's voxel count along an axis, is an
  error naming ``radius``.
- A store larger than its memory budget is filtered chunk by chunk into a new store
  (vgraph.chunked_segmentation): the same functions over tiles with halos of the ball's reach
  (dask-image's ndmorph for masks), the same values; labels stay labels (the store's label flag).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from vgraph import FloatProperty, Inport, OptionProperty, Outport, Processor, PropertyError
from vgraph.chunked_filtering import filtered_store, is_chunked, kernel_plan
from vgraph.chunked_segmentation import overlapping
from vgraph.volume import Volume
from vgraph.volume_filtering import filtered, finite_values, samples_in_memory
from vgraph.volume_segmentation import ball_half_widths, ball_offsets, check_reach, label_values

OPERATIONS = ("dilate", "erode", "open", "close")
STEPS = {"dilate": ("dilate",), "erode": ("erode",), "open": ("erode", "dilate"), "close": ("dilate", "erode")}


class VolumeMorphology(Processor):
    """Dilation, erosion, opening or closing with a ball of a radius in world units."""

    category = "Volume filters"
    inports = [Inport("volume", Volume)]
    outports = [Outport("volume", Volume)]
    operation = OptionProperty("dilate", choices=list(OPERATIONS),
                               doc="dilate, erode, open (erode then dilate) or close (dilate then erode)")
    radius = FloatProperty(1.0, min=0.0, doc="the ball's radius in world units (> 0): an ellipsoid "
                                             "of voxels on an anisotropic grid")

    def check(self) -> None:
        if self.radius <= 0:
            raise PropertyError(f"{self.id}.radius", f"must be above 0, got {self.radius:g}")

    def process(self, volume: Volume) -> Volume:
        who = f"VolumeMorphology '{self.id}'"
        samples_in_memory(volume, who)
        self.check()
        check_reach(f"{self.id}.radius", "ball", ball_half_widths(self.radius, volume.spacing), volume)
        ball = ball_offsets(self.radius, volume.spacing)
        if is_chunked(volume):
            return self._stored(volume, who, ball)
        if volume.holds_labels:
            data = label_values(volume, who)
            return volume.with_data(label_steps(data, self.operation, ball, is_mask(data))
                                    .astype(volume.data.dtype, copy=False))
        data = finite_values(volume, who) if volume.nonfinite_count else volume.data
        return filtered(volume, grey_steps(data, self.operation, ball))

    def _stored(self, volume: Volume, who: str, ball: np.ndarray) -> Volume:
        """A store larger than its budget, slab by slab: each step's halo is the ball's reach, the
        slab's extra slices the reach of every step (vgraph.chunked_segmentation)."""
        steps = STEPS[self.operation]
        reach = np.array(ball.shape) // 2
        settings = {"type": "VolumeMorphology", "operation": self.operation, "radius": self.radius}
        if not volume.holds_labels:
            plan = kernel_plan(volume, who, reach * len(steps), volume.dtype,
                               overlapping(lambda d: grey_steps(d, self.operation, ball), reach[1:] * len(steps),
                                           volume.dtype))
            return filtered_store(volume, plan, who, settings)
        if volume.dtype.kind == "f":
            raise PropertyError(f"{self.id}.radius", f"{volume.source or 'the store'} holds labels as "
                                f"floats: chunked morphology takes integer labels (convert them to integers)")
        low, high = volume.finite_extremes or volume.value_range
        if low >= 0 and high <= 1:  # dask-image's binary morphology, one map_overlap per step
            kernel = masked_steps(steps, ball, volume.dtype)
        else:
            kernel = overlapping(lambda d: label_steps(d, self.operation, ball, False), reach[1:] * len(steps),
                                 volume.dtype)
        plan = kernel_plan(volume, who, reach * len(steps), volume.dtype, kernel)
        plan.holds_labels = True
        return filtered_store(volume, plan, who, settings)


def masked_steps(steps, ball: np.ndarray, dtype):
    """A kernel: the steps of binary morphology of a mask over dask tiles (dask_image.ndmorph,
    with binary_step's border values), in the mask's type."""
    from dask_image import ndmorph

    def kernel(tiles):
        mask = tiles != 0
        for step in steps:
            if step == "dilate":
                mask = ndmorph.binary_dilation(mask, structure=ball, border_value=0)
            else:
                mask = ndmorph.binary_erosion(mask, structure=ball, border_value=1)
        return mask.astype(dtype)
    return kernel


def grey_steps(data: np.ndarray, operation: str, ball: np.ndarray) -> np.ndarray:
    """Grey-value morphology of intensities: scipy.ndimage.grey_dilation / grey_erosion a step."""
    for step in STEPS[operation]:
        grey = ndimage.grey_dilation if step == "dilate" else ndimage.grey_erosion
        data = grey(data, footprint=ball, mode="reflect")
    return data


def label_steps(labels: np.ndarray, operation: str, ball: np.ndarray, binary: bool) -> np.ndarray:
    """The steps on labels: binary morphology of a mask, else the label rules (module docstring)."""
    for step in STEPS[operation]:
        if binary:
            labels = binary_step(step, labels, ball)
        else:
            labels = dilated_labels(labels, ball) if step == "dilate" else eroded_labels(labels, ball)
    return labels


def is_mask(labels: np.ndarray) -> bool:
    """Whether the labels are 0 and 1 only (a mask: binary morphology, one filter a step)."""
    return labels.dtype == bool or (labels.min() >= 0 and labels.max() <= 1)


def binary_step(step: str, mask: np.ndarray, ball: np.ndarray) -> np.ndarray:
    """scipy.ndimage.binary_dilation / binary_erosion of a mask, equal to the mirrored faces of the
    label rules: a mirrored voxel is never nearer than its original to a voxel inside (the ball is
    symmetric along each axis), so beyond the faces nothing counts: 0 for dilation, 1 (nothing
    to erode) for erosion."""
    if step == "dilate":
        return ndimage.binary_dilation(mask, structure=ball, border_value=0)
    return ndimage.binary_erosion(mask, structure=ball, border_value=1)


def dilated_labels(labels: np.ndarray, ball: np.ndarray) -> np.ndarray:
    """Background voxels take the largest label in their ball; labelled voxels keep theirs."""
    grown = ndimage.grey_dilation(labels, footprint=ball, mode="reflect")
    return np.where(labels != 0, labels, grown)


def eroded_labels(labels: np.ndarray, ball: np.ndarray) -> np.ndarray:
    """A voxel keeps its label where its whole ball holds that label (smallest = largest), else 0."""
    low = ndimage.grey_erosion(labels, footprint=ball, mode="reflect")
    high = ndimage.grey_dilation(labels, footprint=ball, mode="reflect")
    return np.where(low == high, labels, np.zeros((), labels.dtype))
