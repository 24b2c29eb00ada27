"""Reading, writing and converting volume files.

    read_volume(path, *, raw=None, time_step=0) -> Volume
    write_volume(volume, path) -> Path

Formats (by extension; a folder is a DICOM series):
  .dat               QVis header + raw file                       (qvis.py)
  .raw / other       headerless raw with raw={...} or a name like x_64x64x64_uint8.raw  (raw.py)
  .nrrd / .nhdr      NRRD, attached or detached, also multi-file   (nrrd_format.py)
  .nii / .nii.gz     NIfTI-1/2                                     (nifti.py)
  .mhd / .mha        MetaImage                                     (metaimage.py)
  folder, .dcm/.ima  DICOM series                                  (dicom_series.py)
  .npy / .npz        NumPy arrays [z, y, x]                        (numpy_format.py)
  .slc               VolVis SLC (8-bit, run-length encoded)         (slc.py)
  .vti               VTK XML ImageData, one scalar array            (vti.py)
  folder .zarr       OME-Zarr image, read lazily as a BrickedVolume (vgraph/bricks/store.py);
                     so is any folder holding a zarr group (zarr.json or .zgroup)
Writing: .npy, .npz, .nrrd, .nii, .nii.gz, .mha, .vti (writers.py), atomically; all but .npy keep
the grid. Converting: ``vgraph convert`` writes any of these as an OME-Zarr pyramid of bricks
(convert.py), reading the input slab by slab where its format allows (slabs.py). io sits above
vgraph.bricks: it opens and writes stores through it, and the bricks never import io.

Every reader returns a Volume with data [z, y, x] in native byte order (file order, x fastest;
the voxels are never resampled), spacing and origin (x, y, z) and direction, in RAS patient space
(orientation.py converts what the file declares), declared_range where the header states one,
source = str(path) and time_steps. Files with a time axis (4D NIfTI, NRRD whose last axis has
kind ``time``, 4D MetaImage, NumPy [t, z, y, x]) give the time point ``time_step``; asking any
file for one it does not hold raises TimeStepError. Any problem with the input raises
VolumeFileError naming the file and the header field; float NaN/Inf voxels load with a
NonFiniteVoxelsWarning. docs/guide/volumes.md has the details per format.
"""

from __future__ import annotations

import os
from pathlib import Path

from vgraph.bricks.volume import BrickedVolume
from vgraph.errors import TimeStepError, VolumeFileError
from vgraph.io._common import NonFiniteVoxelsWarning, check_time_step, file_problem, regular_file
from vgraph.io.dicom_series import read_dicom_series
from vgraph.io.metaimage import read_metaimage
from vgraph.io.nifti import read_nifti
from vgraph.io.nrrd_format import read_nrrd
from vgraph.io.numpy_format import read_npy, read_npz
from vgraph.io.qvis import read_qvis
from vgraph.io.raw import read_raw
from vgraph.io.slc import read_slc
from vgraph.io.vti import read_vti
from vgraph.io.writers import WRITABLE_EXTENSIONS, write_volume
from vgraph.memory import allocation_size, out_of_memory_reason
from vgraph.volume import Volume

__all__ = ["read_volume", "write_volume", "SUPPORTED_EXTENSIONS", "WRITABLE_EXTENSIONS",
           "FILE_FILTERS", "NonFiniteVoxelsWarning", "TimeStepError", "VolumeFileError",
           "file_problem"]


def read_zarr(path, time_step: int = 0) -> Volume:
    """An OME-Zarr image as a BrickedVolume: metadata now, voxels when a consumer needs them
    (within the default memory budget; docs/guide/large-data.md)."""
    return BrickedVolume.open(path, time_step=time_step)


def is_zarr_group(path) -> bool:
    """Whether ``path`` is a folder holding a zarr group: an OME-Zarr image inside a store, such
    as STORE.zarr/labels/cells or a bioformats2raw series STORE.zarr/0, whatever its name."""
    return any(os.path.isfile(os.path.join(path, name)) for name in ("zarr.json", ".zgroup"))


_READERS = {
    ".dat": read_qvis,
    ".raw": None,  # needs the raw description
    ".nrrd": read_nrrd, ".nhdr": read_nrrd,
    ".nii": read_nifti, ".nii.gz": read_nifti,
    ".mhd": read_metaimage, ".mha": read_metaimage,
    ".dcm": read_dicom_series, ".ima": read_dicom_series,
    ".npy": read_npy, ".npz": read_npz,
    ".slc": read_slc, ".vti": read_vti,
    ".zarr": read_zarr,  # a folder
}
SUPPORTED_EXTENSIONS: tuple[str, ...] = tuple(_READERS)
# Readers that know a time axis take time_step; every other file holds one time point.
_TIME_READERS = {read_nifti, read_nrrd, read_metaimage, read_npy, read_npz, read_zarr}

# For GUI file dialogs: (label, extensions). A DICOM series is opened by picking one of its files.
FILE_FILTERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("QVis volume", (".dat",)),
    ("Raw volume", (".raw",)),
    ("NRRD", (".nrrd", ".nhdr")),
    ("NIfTI", (".nii", ".nii.gz")),
    ("MetaImage", (".mhd", ".mha")),
    ("DICOM series", (".dcm", ".ima")),
    ("NumPy array", (".npy", ".npz")),
    ("VolVis SLC", (".slc",)),
    ("VTK image data", (".vti",)),
    ("OME-Zarr store", (".zarr",)),
)


def read_volume(path, *, raw: dict | None = None, time_step: int = 0) -> Volume:
    """Load a volume file, or a DICOM series folder; of a file with a time axis, the time point
    ``time_step`` (0 = the first).

    ``raw`` describes a headerless raw file: {'dims': (x, y, z), 'dtype': 'uint16',
    'endianness': 'little' | 'big', 'spacing': (x, y, z), 'origin': (x, y, z), 'offset': bytes}.
    Given, it forces raw reading whatever the extension."""
    path = Path(path)
    reader = _reader_for(path, raw)
    try:
        if reader in _TIME_READERS:
            return reader(path, time_step=time_step)
        check_time_step(path, time_step, 1)  # before reading a file that cannot hold it
        return reader(path)
    except MemoryError as error:  # past the readers' own check (a library's copy, say): named
        raise VolumeFileError(path, out_of_memory_reason("reading it", allocation_size(error))) from error


def describes_itself(path: Path) -> bool:
    """Whether ``path`` is a file (or folder) whose format carries its own grid and type, so that
    a raw description does not apply to it (NRRD, NIfTI, DICOM, a store ...; not .raw)."""
    return os.path.isdir(path) or _READERS.get(extension_of(Path(path))) is not None


def _reader_for(path: Path, raw: dict | None):
    if raw is not None:
        return lambda p: read_raw(p, raw)
    if os.path.isdir(path):  # False for a name too long: regular_file names that
        return read_zarr if extension_of(path) == ".zarr" or is_zarr_group(path) else read_dicom_series
    regular_file(path)  # before anything opens it: a FIFO would block, /dev/zero never end
    ext = extension_of(path)
    if ext == ".zarr":
        return read_zarr  # not a folder: it names the problem
    if ext == ".raw":
        return read_raw
    if ext in _READERS:
        return _READERS[ext]
    if _looks_like_dicom(path):
        return read_dicom_series
    raise VolumeFileError(path, f"unknown volume file type {path.suffix or '(no extension)'!r}; "
                                f"supported: {', '.join(SUPPORTED_EXTENSIONS)}, a DICOM folder, or "
                                f"raw={{...}} for headerless data", "extension")


def extension_of(path: Path) -> str:
    name = path.name.lower()
    return ".nii.gz" if name.endswith(".nii.gz") else path.suffix.lower()


def _looks_like_dicom(path: Path) -> bool:
    """DICOM Part 10 files have 'DICM' after a 128-byte preamble, whatever their name."""
    try:
        with open(path, "rb") as fh:
            fh.seek(128)
            return fh.read(4) == b"DICM"
    except OSError:
        return False
