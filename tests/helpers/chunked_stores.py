"""The stores of the chunk-by-chunk tests (test_chunked_filters, test_chunked_segmentation): a
volume written as a store of 16^3 bricks, opened with a memory budget it exceeds, read back whole;
and the cache and tile size those tests run with."""

from pathlib import Path

from vgraph.bricks.volume import BrickedVolume
from vgraph.io import write_volume
from vgraph.io.convert import convert

BRICK = 16


def write_store(volume, folder: Path, name: str = "tall") -> Path:
    """``folder/name.zarr``, converted from ``volume`` written as ``folder/name.nrrd``."""
    write_volume(volume, folder / f"{name}.nrrd")
    convert(folder / f"{name}.nrrd", folder / f"{name}.zarr", brick=BRICK, progress=False)
    return folder / f"{name}.zarr"


def over_budget(path: Path, budget_mb: float) -> BrickedVolume:
    """The store opened with a budget below its size (so it is processed chunk by chunk)."""
    volume = BrickedVolume.open(path, memory_budget_mb=budget_mb)
    assert not volume.fits_budget
    return volume


def whole(volume):
    """The voxels of a processed store, read with a budget they fit."""
    assert isinstance(volume, BrickedVolume)
    return BrickedVolume.open(volume.source, memory_budget_mb=1000).data


def chunked_cache(tmp_path: Path, monkeypatch, tile: int) -> Path:
    """VGRAPH_CACHE in ``tmp_path/cache`` (returned) and tiles of ``tile`` x ``tile`` voxels, so halos
    cross tiles along y and x as well as z."""
    monkeypatch.setenv("VGRAPH_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr("vgraph.chunked_filtering.TILE", tile)
    return tmp_path / "cache"
