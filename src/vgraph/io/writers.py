"""Saving volumes (the VolumeWriter sink uses this): .npy, .npz, .nrrd, .nii, .nii.gz, .mha, .vti.

Writes are atomic: the file is written under a temporary name in the target folder, flushed to
disk, and moved over the target with os.replace. If anything fails the temporary file is removed
and an existing file of that name is left untouched.

What each format keeps (every one but .npy keeps the grid: read back by vgraph, nibabel,
SimpleITK or VTK, each voxel lands where it was; docs/guide/volumes.md, "Writing volumes"):
  .npy      values only ([z, y, x]); spacing, origin and direction are NOT stored
  .npz      data, spacing, origin, direction, value_range (if declared)
  .nrrd     values (gzip), space right-anterior-superior, space directions (the affine's
            columns), space origin, value range (``vgraph value range`` key)
  .nii(.gz) values, the affine as sform and qform (code 1), value range (cal_min/cal_max, read
            back only from files vgraph wrote)
  .mha      values (zlib), TransformMatrix, Offset and AnatomicalOrientation in ITK's LPS,
            ElementSpacing, value range (ElementMin/ElementMax)
  .vti      values (zlib), Origin, Spacing, Direction; no value range
"""

from __future__ import annotations

import os
from pathlib import Path

from vgraph.atomic import atomic_path
from vgraph.errors import OutputFileError, VolumeFileError
from vgraph.io.metaimage import write_metaimage
from vgraph.io.nifti import write_nifti
from vgraph.io.nrrd_format import write_nrrd
from vgraph.io.numpy_format import write_npy, write_npz
from vgraph.io.vti import write_vti
from vgraph.memory import out_of_memory
from vgraph.volume import Volume


def _write_with_handle(writer):
    def write(volume: Volume, file: Path) -> None:
        with open(file, "wb") as fh:
            writer(volume, fh)
    return write


WRITERS = {
    ".npy": _write_with_handle(write_npy),
    ".npz": _write_with_handle(write_npz),
    ".nrrd": write_nrrd,
    ".nii": write_nifti,
    ".nii.gz": write_nifti,
    ".mha": write_metaimage,
    ".vti": write_vti,
}
WRITABLE_EXTENSIONS = tuple(WRITERS)


def writable_extension(path: Path) -> str | None:
    name = path.name.lower()
    return next((ext for ext in sorted(WRITERS, key=len, reverse=True) if name.endswith(ext)), None)


def write_volume(volume: Volume, path, inside=None) -> Path:
    """Save ``volume`` to ``path`` (format from the extension), atomically; ``inside``: the
    folders the write must stay in (vgraph.atomic). Returns the path."""
    path = Path(path)
    ext = writable_extension(path)
    if ext is None:
        raise VolumeFileError(path, f"cannot write this file type; use one of "
                                    f"{', '.join(WRITABLE_EXTENSIONS)}", "extension")
    if not isinstance(volume, Volume):
        raise VolumeFileError(path, f"expected a Volume to write, got {type(volume).__name__}")
    folder = path.parent if str(path.parent) else Path(".")
    if not os.path.isdir(folder):
        raise VolumeFileError(path, f"folder {str(folder)!r} does not exist", "path")
    try:
        with atomic_path(path, suffix=ext, inside=inside) as temporary:  # the extension picks the compression
            WRITERS[ext](volume, temporary)
    except VolumeFileError:
        raise
    except OutputFileError as error:  # the system's reason, or a folder outside where it may write
        raise VolumeFileError(path, f"writing failed, existing file left untouched: {error.reason}",
                              "path") from error
    except MemoryError as exc:
        raise out_of_memory(exc, f"writing {path}") from exc
    except Exception as exc:
        raise VolumeFileError(path, f"writing failed, existing file left untouched: "
                                    f"{type(exc).__name__}: {exc}") from exc
    return path
