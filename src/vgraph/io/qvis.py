"""QVis .dat headers (Roettger's QVis, also read by Voreen) with their .raw data file.

A .dat file is ``Key: value`` lines; keys are matched case-insensitively:
  ObjectFileName: neghip.raw     data file, relative to the .dat's folder        required
  Resolution:     66 66 66       x y z voxel counts                              required
  SliceThickness: 1 1 1          x y z spacing                                   default 1 1 1
  Format:         UCHAR          UCHAR | USHORT | USHORT_12 | FLOAT (+ CHAR, SHORT, UINT, INT,
                                 DOUBLE)                                         required
  ObjectModel:    I              only scalar intensity ('I') volumes are read
  Endianness:     LITTLE         optional (QVis files are little-endian)
Other keys (TaggedFileName, NbrTags, ObjectType, GridType, ...) are ignored. ``USHORT_12`` is
read as uint16 and declares no value range: 12 bits is the storage's width, not the data's range
(an MR scan of 0..400 mapped over [0, 4095] renders nearly black), so the range is min..max like
any other type's. The raw file must hold exactly the described bytes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vgraph.errors import VolumeFileError
from vgraph.io._common import (check_dims, check_spacing, make_volume, parse_numbers,
                               read_header_bytes, read_raw_array, regular_file)
from vgraph.volume import Volume

# Format word -> dtype
FORMATS = {
    "UCHAR": "u1", "CHAR": "i1", "USHORT": "u2", "USHORT_12": "u2", "SHORT": "i2",
    "UINT": "u4", "INT": "i4", "FLOAT": "f4", "DOUBLE": "f8",
}
_ENDIAN_WORDS = {"LITTLE": "<", "LITTLE_ENDIAN": "<", "BIG": ">", "BIG_ENDIAN": ">"}


def read_qvis(path) -> Volume:
    path = Path(path)
    fields = parse_dat(path)
    for key in ("objectfilename", "resolution", "format"):
        if key not in fields:
            raise VolumeFileError(path, "required field is missing", _display(key))
    dims = check_dims(parse_numbers(fields["resolution"], path, "Resolution", 3, int), path,
                      "Resolution")
    spacing = (1.0, 1.0, 1.0)
    if "slicethickness" in fields:
        spacing = check_spacing(parse_numbers(fields["slicethickness"], path, "SliceThickness"),
                                path, "SliceThickness")
    fmt = fields["format"].upper()
    if fmt not in FORMATS:
        raise VolumeFileError(path, f"unknown Format {fields['format']!r}; known: "
                                    f"{', '.join(FORMATS)}", "Format")
    model = fields.get("objectmodel", "I").upper()
    if model not in ("I", ""):
        raise VolumeFileError(path, f"only scalar intensity volumes (ObjectModel: I) are supported, "
                                    f"got {fields['objectmodel']!r}", "ObjectModel")
    order = _byte_order(fields, path)
    type_code = FORMATS[fmt]
    data_file = regular_file(path.parent / fields["objectfilename"], path, "ObjectFileName")
    flat = read_raw_array(data_file, np.dtype(order + type_code), dims[0] * dims[1] * dims[2],
                          size_field="Resolution", header=path)
    return make_volume(flat.reshape(dims[::-1]), path, spacing=spacing)


def parse_dat(path: Path) -> dict[str, str]:
    """Lower-cased key -> value text. Lines without a colon are refused (not a .dat file)."""
    text = read_header_bytes(path).decode("latin-1")
    fields = {}
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        key, colon, value = line.partition(":")
        if not colon or not key.strip():
            raise VolumeFileError(path, f"line {number} is not 'Key: value': {line[:60]!r}",
                                  f"line {number}")
        fields[key.strip().lower()] = value.strip()
    return fields


def _byte_order(fields: dict, path: Path) -> str:
    word = fields.get("endianness", fields.get("endianess", "LITTLE")).upper()
    if word not in _ENDIAN_WORDS:
        raise VolumeFileError(path, f"unknown byte order {word!r}; use LITTLE or BIG", "Endianness")
    return _ENDIAN_WORDS[word]


def _display(key: str) -> str:
    return {"objectfilename": "ObjectFileName", "resolution": "Resolution",
            "format": "Format"}.get(key, key)
