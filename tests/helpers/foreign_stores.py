"""Other tools' OME-Zarr stores for the tests that read them (tests/test_foreign_ome_zarr.py,
test_paged_bricks.py, test_brick_walk_order.py): an image written by ome-zarr-py, the store
opened with no level dropped, and the ramp both ray casters draw such stores with. Importing this
module skips the test without ome-zarr-py (the test extra, pyproject.toml)."""

import warnings

import pytest
import zarr

from vgraph.bricks.store import BrickStore
from vgraph.bricks.store_metadata import StoreLevelsWarning
from vgraph.transfer_function import TransferFunction

ome_writer = pytest.importorskip("ome_zarr.writer")  # the test extra (pyproject.toml)
from ome_zarr.format import FormatV04, FormatV05  # noqa: E402

FORMATS = {"0.4": FormatV04, "0.5": FormatV05}
RAMP = TransferFunction(points=[(0.0, 0, 0, 0, 0), (1.0, 1, 1, 1, 1)])


def ome_zarr_py_image(path, data, version="0.5", axes="zyx", **options):
    """``data`` written by ome-zarr-py's write_image (its default pyramid: x and y halved and
    floored per level, z kept) into a new store of the format's zarr version."""
    group = zarr.open_group(str(path), mode="w", zarr_format=2 if version == "0.4" else 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ome-zarr-py's own deprecation notes
        ome_writer.write_image(data, group, axes=axes, fmt=FORMATS[version](), **options)
    return path


def opened(path, **options) -> BrickStore:
    with warnings.catch_warnings():
        warnings.simplefilter("error", StoreLevelsWarning)  # no level may be dropped
        return BrickStore(path, **options)
