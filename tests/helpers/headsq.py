"""The CT head the volume filter and measuring tests read (../shared/data/ct_head_headsq, quarter
resolution: int16, spacing 3.2 x 3.2 x 1.5, an anisotropic grid), and a turned, mirrored copy."""

import numpy as np
import pytest

from helpers.paths import DATA
from vgraph.io import read_volume

TILT = ((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0))  # a turned, mirrored grid (det 1)


def read_head():
    """The head as read, or the test skipped where the shared data is missing."""
    path = DATA / "ct_head_headsq" / "quarter.nhdr"
    if not path.is_file():
        pytest.skip(f"shared data set {path} not found")
    volume = read_volume(path)
    assert volume.spacing == (3.2, 3.2, 1.5) and volume.data.dtype == np.int16
    return volume


def turned(volume):
    """The same voxels on a grid turned by TILT and moved off the origin."""
    return volume.with_overrides(direction=TILT, origin=(-40.0, 25.0, 17.5))
