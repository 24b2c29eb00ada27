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
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from vgraph import FloatProperty, Inport, OptionProperty, Outport, Processor, PropertyError
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
        if volume.holds_labels:
            data = label_values(volume, who)
            binary = is_mask(data)
            for step in STEPS[self.operation]:
                if binary:
                    data = binary_step(step, data, ball)
                else:
                    data = dilated_labels(data, ball) if step == "dilate" else eroded_labels(data, ball)
            return volume.with_data(data.astype(volume.data.dtype, copy=False))
        data = finite_values(volume, who) if volume.nonfinite_count else volume.data
        for step in STEPS[self.operation]:
            grey = ndimage.grey_dilation if step == "dilate" else ndimage.grey_erosion
            data = grey(data, footprint=ball, mode="reflect")
        return filtered(volume, data)


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
