"""Chunked segmentation: the segmentation processors (VolumeMorphology, GradientMagnitude,
ConnectedComponents, VolumeMath, VolumeMask) on a store larger than its memory budget, chunk by
chunk into a new store (docs/guide/volume-filters.md, "Stores larger than memory"), through
vgraph.chunked_filtering's plans, cache and atomic writer.

- Kernels (morphology, gradients): ``overlapping`` runs the processor's own in-memory function
  over the tiles of a slab with dask's map_overlap (halos of the kernel's reach along y and x,
  boundary 'none': the function's own boundary rule applies only at the volume's faces), and the
  slab carries the reach more slices along z (kernel_plan); dask-image's ndmorph does the binary
  steps of masks the same way. So each voxel is computed from the same voxels by the same code
  as in memory: the same values, bit for bit.
- Voxel by voxel (math, mask): each slab of the output from the same slab of each input (a store's
  rows, an in-memory volume's slices, or a volume resampled onto the slab's grid) by the
  processor's own combination.
- Connected components: dask-image's labelling across chunks (dask_image.ndmeasure.label's
  scheme, with scipy's functions: each tile labelled by scipy.ndimage.label with numbers unique
  over the volume, the labels touching across tile boundaries joined by the connected components
  of their graph). Not dask_image.ndmeasure.label itself (its only public function for it):
  computed whole it holds every tile's labels until the graph is solved, four bytes a voxel,
  beyond any budget. The tiles' labels go to a scratch zarr array instead, and the boundaries
  are read back from it a band of slices at a time. Then
  one pass counts each component's voxels and finds its first voxel in memory order, so the
  numbering is the in-memory one (largest first, a tie by the first voxel met), and the last pass
  writes it.
"""

from __future__ import annotations

import shutil
import uuid

import numpy as np

from vgraph.bricks.volume import BrickedVolume
from vgraph.chunked_filtering import (SlabPlan, cache_folder, check_working_memory, filtered_store,
                                      output_brick, tile_size)
from vgraph.errors import VGraphError
from vgraph.volume import Volume
from vgraph.volume_segmentation import sampled_at, smallest_label_type


BAND_VOXELS = 2**20  # voxels of the component count's np.unique at once
LABEL_DTYPE = np.dtype(np.int32)  # scipy.ndimage.label's output type: the tiles' labels


def rows_of(volume: Volume, z0: int, z1: int) -> np.ndarray:
    """Slices z0 .. z1 - 1 ([z, y, x]) of a store's level 0 or of an in-memory volume."""
    if volume.bricks is not None and not volume.fits_budget:
        return volume.bricks.read(0, (z0, 0, 0), (z1, *volume.shape[1:]))
    return volume.data[z0:z1]


def voxel_type(volume: Volume) -> np.dtype:
    """The type of a volume's voxels, without reading a store's."""
    return np.dtype(volume.dtype) if isinstance(volume, BrickedVolume) else volume.data.dtype


# --- kernels over tiles with halos --------------------------------------------------------------
def overlapping(function, reach_yx, dtype):
    """A kernel for chunked_filtering.kernel_plan: ``function`` (an in-memory filter of a [z, y, x]
    array) over a slab's tiles with halos of ``reach_yx`` voxels (boundary 'none': at the volume's
    faces the function's own boundary rule, elsewhere real voxels)."""
    def kernel(tiles):
        depth = {0: 0, 1: int(reach_yx[0]), 2: int(reach_yx[1])}
        return tiles.map_overlap(function, depth=depth, boundary="none", dtype=np.dtype(dtype),
                                 meta=np.empty((0, 0, 0), dtype=dtype))
    return kernel


# --- voxel by voxel -----------------------------------------------------------------------------
def on_slab_grid(volume: Volume, grid: Volume, order: int):
    """A row reader: ``volume`` sampled on the slices z0 .. z1 - 1 of ``grid`` (sampled_at)."""
    shift = np.eye(4)

    def rows(z0: int, z1: int) -> np.ndarray:
        shift[2, 3] = z0  # the slab's first slice is the grid's slice z0
        return sampled_at(volume, grid.affine @ shift, (z1 - z0, *grid.dims[1::-1]), order)
    return rows


def elementwise_plan(anchor: BrickedVolume, grid: Volume, readers, combine, dtype, declared_range,
                     holds_labels: bool) -> SlabPlan:
    """A plan whose slab z0 .. z1 is ``combine(*(reader(z0, z1) for reader in readers))`` on
    ``grid``'s voxels; ``anchor``: the store that sets the bricks and the memory budget."""
    def compute(z0: int, z1: int) -> np.ndarray:
        return np.ascontiguousarray(combine(*(read(z0, z1) for read in readers)), dtype=dtype)

    plane = grid.dims[0] * grid.dims[1]
    bz = output_brick(anchor)[2]
    return SlabPlan(tuple(grid.dims[::-1]), np.dtype(dtype), grid.spacing, grid.origin, declared_range,
                    compute, len(readers) * bz * plane, holds_labels=holds_labels, source=anchor.source,
                    temporary_bytes=2 * bz * plane * 8)


def input_key(volume: Volume) -> dict:
    """What names a volume's voxels in a cache key: a store's path and modification time, an
    in-memory volume's hash (its voxels are in memory: hashing them is a pass over them)."""
    import hashlib
    if volume.bricks is not None and volume.source:
        from pathlib import Path
        metadata = Path(volume.source) / "zarr.json"
        stamp = metadata.stat().st_mtime_ns if metadata.is_file() else uuid.uuid4().hex
        return {"store": str(Path(volume.source).resolve()), "stamp": stamp, "grid": str(volume.affine.tolist())}
    digest = hashlib.sha256(np.ascontiguousarray(volume.data).view(np.uint8).reshape(-1)).hexdigest()
    return {"voxels": digest, "dtype": str(volume.data.dtype), "grid": str(volume.affine.tolist()),
            "labels": volume.holds_labels}


# --- connected components -----------------------------------------------------------------------
def component_store(volume: BrickedVolume, who: str, foreground, structure, min_voxels: int,
                    check_count, settings: dict) -> BrickedVolume:
    """The connected components of a store's ``foreground`` (a function of a block of voxels) as a
    label store numbered as in memory (module docstring); ``check_count(kept, found)`` refuses
    too many labels. The result carries ComponentLabels' ``voxel_counts`` (voxels of label l at
    [l - 1]), ``world_volumes`` and ``component_count``."""
    depth, rows_y, cols_x = volume.shape
    bz = output_brick(volume)[2]
    ty, tx = tile_size(volume)
    state = {}
    slab = bz * rows_y * cols_x
    # uint8 until the count is known (filtered_store checks again with the labels' own type)
    plan = SlabPlan(volume.shape, np.dtype(np.uint8), volume.spacing, volume.origin, None,
                    lambda z0, z1: state["numbering"][state["tiles"][z0:z1]], slab,
                    holds_labels=True, source=volume.source,
                    # a slab's foreground (bool), its tile labels (int32) and their components
                    # (int32), and a band's np.unique (its copy, order, index and counts)
                    temporary_bytes=slab * (1 + 4 + 4) + min(slab, BAND_VOXELS) * (4 + 8 + 8 + 8))
    check_working_memory(volume, plan, who)
    scratch = cache_folder() / "scratch" / f"components-{uuid.uuid4().hex}.zarr"
    try:
        tiles, total = labelled_tiles(volume, foreground, structure, scratch, (bz, ty, tx))
        state["tiles"] = tiles
        joined = joined_components(tiles, structure, total)
        sizes, first = component_extents(tiles, joined, bz)
        numbering, counts = numbered_by_size(sizes, first, min_voxels)
        check_count(counts.size, sizes.size - 1)
        state["numbering"] = numbering[joined]  # tile label -> final label, in one lookup
        plan.dtype = state["numbering"].dtype
        plan.declared_range = (0.0, float(max(1, counts.size)))
        plan.temporary_bytes += state["numbering"].nbytes + joined.nbytes
        out = filtered_store(volume, plan, who, settings)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    # what ComponentLabels offers in memory
    out.voxel_counts, out.component_count = counts, int(counts.size)
    out.world_volumes = counts * float(np.prod(volume.spacing))
    return out


def labelled_tiles(volume: BrickedVolume, foreground, structure, scratch, chunks):
    """Every tile's components by scipy.ndimage.label, numbered on from the previous tiles'
    (dask_image.ndmeasure's first step), written to a scratch zarr array: (it, the count)."""
    import zarr
    from scipy import ndimage
    depth, rows_y, cols_x = volume.shape
    tiles = zarr.create_array(str(scratch), shape=volume.shape, chunks=chunks, dtype=LABEL_DTYPE,
                              fill_value=0)
    total = 0
    for z0 in range(0, depth, chunks[0]):
        z1 = min(depth, z0 + chunks[0])
        mask = foreground(rows_of(volume, z0, z1))
        out = np.zeros(mask.shape, dtype=LABEL_DTYPE)
        for y0 in range(0, rows_y, chunks[1]):
            for x0 in range(0, cols_x, chunks[2]):
                part = (slice(None), slice(y0, y0 + chunks[1]), slice(x0, x0 + chunks[2]))
                labels, count = ndimage.label(mask[part], structure=structure, output=LABEL_DTYPE)
                out[part] = np.where(labels > 0, labels + LABEL_DTYPE.type(total), 0)
                total += count
        if total > np.iinfo(LABEL_DTYPE).max:
            raise VGraphError(f"{volume.source or 'the store'}: more than {np.iinfo(LABEL_DTYPE).max} "
                              f"pieces of components in its tiles: too many to number")
        tiles[z0:z1] = out
    return tiles, total


def joined_components(tiles, structure, total: int) -> np.ndarray:
    """tile label -> component (0 the background): the tile labels that touch across a boundary
    between tiles joined by scipy's connected_components, as dask-image's label joins them. Two
    voxels that touch (by ``structure``) in different tiles lie on either side of a boundary along
    some axis, so they touch in the two slices around it (``touching``). The scratch array is read
    a band of a tile's slices at a time: its boundaries along y and x, and along z with the next
    band's first slice (a face a task would cost more to schedule than to compute)."""
    import scipy.sparse
    from scipy.sparse.csgraph import connected_components
    depth = tiles.shape[0]
    bz, ty, tx = tiles.chunks
    pairs = [np.zeros((2, 0), dtype=np.int64)]
    band = tiles[0:min(depth, bz)]
    for z0 in range(0, depth, bz):
        for axis, step in ((1, ty), (2, tx)):
            for edge in range(step, tiles.shape[axis], step):
                pairs.append(touching(np.take(band, [edge - 1, edge], axis=axis), structure))
        if z0 + bz < depth:
            following = tiles[z0 + bz:min(depth, z0 + 2 * bz)]
            pairs.append(touching(np.concatenate([band[-1:], following[:1]]), structure))
            band = following
    i, j = np.concatenate(pairs, axis=1)
    graph = scipy.sparse.coo_matrix((np.ones_like(i), (i, j)), shape=(total + 1, total + 1)).tocsr()
    # node 0 (the background) touches nothing: it is component 0
    return connected_components(graph, directed=False)[1]


def touching(face: np.ndarray, structure) -> np.ndarray:
    """(2, M) edges between tile labels: those in one piece of ``face`` (two slices across a
    boundary between tiles, labelled by scipy.ndimage.label with ``structure``) are chained
    together, each to the next."""
    from scipy import ndimage
    pieces = ndimage.label(face, structure=structure)[0]
    inside = pieces > 0
    # (piece, tile label) once each, sorted by piece: a piece's labels are adjacent columns
    found = np.unique(np.stack([pieces[inside], face[inside]]).astype(np.int64), axis=1)
    chained = np.flatnonzero(np.diff(found[0]) == 0)
    return np.stack([found[1][chained], found[1][chained + 1]])


def component_extents(tiles, joined: np.ndarray, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Each component's voxel count and the memory-order index of its first voxel, a band of
    ``rows`` slices and some rows along y at a time (BAND_VOXELS: np.unique sorts a copy). In a
    box of the volume, memory order is the box's own C order, so the first voxel np.unique finds
    in a band is the band's first in the volume's order too."""
    count = int(joined.max()) + 1
    sizes = np.zeros(count, dtype=np.int64)
    first = np.full(count, np.iinfo(np.int64).max, dtype=np.int64)
    depth, rows_y, cols_x = tiles.shape
    band_rows = max(1, BAND_VOXELS // (rows * cols_x))
    for z0 in range(0, depth, rows):
        slab = tiles[z0:min(depth, z0 + rows)]
        for y0 in range(0, rows_y, band_rows):
            band = joined[slab[:, y0:y0 + band_rows]]
            present, index, counts = np.unique(band.reshape(-1), return_index=True, return_counts=True)
            sizes[present] += counts
            z, y, x = np.unravel_index(index, band.shape)
            np.minimum.at(first, present, np.ravel_multi_index((z + z0, y + y0, x), tiles.shape))
    return sizes, first


def numbered_by_size(sizes: np.ndarray, first: np.ndarray, min_voxels: int) -> tuple[np.ndarray, np.ndarray]:
    """component -> final label, from the largest down (a tie: the first voxel met first, as
    scipy numbers them in memory), those under ``min_voxels`` 0; and the kept sizes."""
    order = np.lexsort((first[1:], -sizes[1:]))
    kept = order[sizes[1:][order] >= min_voxels]
    numbering = np.zeros(sizes.size, dtype=smallest_label_type(kept.size))
    numbering[kept + 1] = np.arange(1, kept.size + 1)
    return numbering, sizes[1:][kept]
