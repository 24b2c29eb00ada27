"""What ``vgraph run`` writes: ``-o`` (8-bit PNG), ``--data`` (the format follows the extension)
and the deprecated ``--npy``. Everything that can be refused without evaluating (a path that
cannot be written, an unknown extension, a format the target's data type has no writer for) is
refused before the network is evaluated. Every file is written atomically.

    target carries   -o OUT.png   --data .npy            .npz                         .nrrd .nii .nii.gz
    Image            8-bit RGBA   float32 H x W x 4      key "image": float32 H x W x 4   refused
    Volume           refused      values [z, y, x] only  data, spacing, origin,       values, spacing, origin
                                                          value_range (if declared)    (io.write_volume)
    arrays, numbers  refused      the array              key "data"                   refused
    Table            refused      refused (--data OUT.csv: a header of names [units], a row per row)
    VolumeStatistics refused      refused (--data OUT.json: VolumeStatistics.as_dict(), VolumeInfo's)
"""

from __future__ import annotations

import json
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vgraph.atomic import atomic_path, check_output_path, write_text_atomic
from vgraph.errors import VGraphError
from vgraph.image import Image
from vgraph.imagefile import write_png
from vgraph.io import WRITABLE_EXTENSIONS, write_volume
from vgraph.io.writers import writable_extension
from vgraph.scheduler import BlankImageWarning, to_numpy
from vgraph.table import Table
from vgraph.volume import Volume
from vgraph.volume_statistics import VolumeStatistics

IMAGE_FORMATS = (".npy", ".npz")
VOLUME_FORMATS = WRITABLE_EXTENSIONS  # .npy .npz .nrrd .nii .nii.gz
DATA_FORMATS_TEXT = (".npy or .npz (images, volumes), .nrrd, .nii, .nii.gz, .mha or .vti (volumes), .csv (tables), "
                     ".json (volume statistics)")
TABLE_FORMAT = ".csv"
STATISTICS_FORMAT = ".json"  # what VolumeInfo's info is written as
SOURCE_VOLUME = "source.volume"  # what the network made for a data file reads (volume_network)


@dataclass(frozen=True)
class Output:
    option: str  # "-o", "--data" or "--npy", for messages
    path: Path
    format: str  # ".png", ".npy", ".npz", ".nrrd", ".nii", ".nii.gz" ... or ".csv"

    def __str__(self) -> str:
        return f"{self.option} {self.path}"


def requested_outputs(args) -> list[Output]:
    """The outputs the options ask for, each checked (folder exists, not a folder, a known
    extension for --data); VGraphError (exit 2) otherwise."""
    outputs = []
    if args.output is not None:
        outputs.append(Output("-o", args.output, ".png"))
    for path in args.data:
        name = Path(path).name.lower()
        extension = next((f for f in (TABLE_FORMAT, STATISTICS_FORMAT) if name.endswith(f)), None) \
            or writable_extension(Path(path))
        if extension is None:
            raise VGraphError(f"--data {path}: the extension chooses the format: {DATA_FORMATS_TEXT}")
        outputs.append(Output("--data", path, extension))
    if args.npy is not None:
        print(f"vgraph: warning: --npy is deprecated; use --data {args.npy} (a .npz or .nrrd "
              f"keeps a volume's spacing)", file=sys.stderr)
        outputs.append(Output("--npy", args.npy, ".npy"))
    for output in outputs:
        check_output_path(output.path)  # refuse before a long evaluation, not after
    return outputs


def targets_of(outputs: list[Output], target: str | None, network, from_data_file: bool) -> dict:
    """{target: its outputs}. Run on a data file without --port, a volume-only format (.nrrd,
    .nii, .mha ...) writes the volume read (``source.volume``), the rest the picture: ``vgraph run
    head.nii.gz -o head.png --data head.nrrd`` writes both."""
    groups: dict[str, list[Output]] = {}
    source, port = SOURCE_VOLUME.split(".")
    reads_volume = from_data_file and source in network.processors and network[source].outport(port) is not None
    for output in outputs:
        volume_only = output.format in VOLUME_FORMATS and output.format not in IMAGE_FORMATS
        chosen = SOURCE_VOLUME if reads_volume and volume_only else target
        groups.setdefault(chosen, []).append(output)
    return groups


def check_formats(outputs: list[Output], target: str, data_type: type | None) -> None:
    """Refuse, before evaluating, outputs the target's declared data type cannot go to."""
    for output in outputs:
        problem = _format_problem(output, data_type)
        if problem:
            raise VGraphError(f"{output}: {target} carries {_type_name(data_type)}; {problem}")


def _format_problem(output: Output, data_type: type | None) -> str | None:
    if data_type is None:
        return None  # not known before evaluating: write_outputs checks the data itself
    if issubclass(data_type, VolumeStatistics) or output.format == STATISTICS_FORMAT:
        return None if issubclass(data_type, VolumeStatistics) and output.format == STATISTICS_FORMAT else \
            ("volume statistics are written as JSON: use --data OUT.json" if issubclass(data_type, VolumeStatistics)
             else ".json holds volume statistics only (VolumeInfo's info)")
    if issubclass(data_type, Table) or output.format == TABLE_FORMAT:
        return None if issubclass(data_type, Table) and output.format == TABLE_FORMAT else \
            ("a table is written as CSV: use --data OUT.csv" if issubclass(data_type, Table)
             else ".csv holds tables only")
    if output.format == ".png":
        return None if issubclass(data_type, Image) else \
            f"-o writes images only: use --data OUT.npz ({DATA_FORMATS_TEXT})"
    if output.format == ".npy" or output.format == ".npz" and not issubclass(data_type, Volume):
        return None
    if issubclass(data_type, Volume):
        return None if output.format in VOLUME_FORMATS else f"use {DATA_FORMATS_TEXT}"
    return f"{output.format} holds volumes only: use .npy or .npz" + \
        (" (or -o OUT.png)" if issubclass(data_type, Image) else "")


def write_outputs(outputs: list[Output], target: str, data, blank_warning) -> None:
    """Write ``data`` (what ``target`` holds after evaluating) to every output. ``blank_warning``
    (pixels -> message or None) is asked once about an image that is written."""
    if data is None:
        raise VGraphError(f"{target} holds no data (was it evaluated? is its input connected?)")
    check_formats(outputs, target, type(data))
    if isinstance(data, Image) and outputs:
        pixels = data.to_numpy()
        message = blank_warning(pixels)
        if message:
            warnings.warn(BlankImageWarning(message), stacklevel=2)
    for output in outputs:
        if isinstance(data, Image):
            _write_image(output, pixels)
        elif isinstance(data, Table):
            data.to_csv(output.path)  # atomic
        elif isinstance(data, VolumeStatistics):
            write_text_atomic(output.path, json.dumps(data.as_dict(), indent=2) + "\n")
        elif isinstance(data, Volume) and output.option == "--data":
            write_volume(data, output.path)  # atomic; the format follows the extension
            if output.format == ".npy":
                print(f"vgraph: note: {output.path} holds the voxel values [z, y, x] only, not "
                      f"the spacing and origin: .npz, .nrrd or .nii.gz keep them", file=sys.stderr)
        else:
            _write_array(output, _as_array(data, target))


def write_image_outputs(outputs: list[Output], pixels: np.ndarray) -> None:
    """Write an image already read back (float32 H x W x 4; the one ``vgraph run --cluster``
    assembles from tiles) to every output, as write_outputs writes an Image."""
    for output in outputs:
        _write_image(output, pixels)


def _write_image(output: Output, pixels: np.ndarray) -> None:
    if output.format == ".png":
        write_png(output.path, pixels)
    elif output.format == ".npz":
        with atomic_path(output.path, suffix=".npz") as temporary:
            np.savez_compressed(temporary, image=pixels)
    else:
        _write_array(output, pixels)


def _write_array(output: Output, array: np.ndarray) -> None:
    with atomic_path(output.path, suffix=output.format) as temporary:
        if output.format == ".npz":
            np.savez_compressed(temporary, data=array)
        else:
            np.save(temporary, array, allow_pickle=False)


def _as_array(data, target: str) -> np.ndarray:
    plain = isinstance(data, (int, float, np.number)) and not isinstance(data, bool)
    array = np.asarray(data) if plain else np.asarray(to_numpy(data))
    if array.dtype.kind not in "biufc":
        raise VGraphError(f"{target} holds {type(data).__name__}, which has no array form to write")
    return array


def _type_name(data_type: type | None) -> str:
    return "data of unknown type" if data_type is None else \
        ("an image" if issubclass(data_type, Image) else
         "a volume" if issubclass(data_type, Volume) else
         "a table" if issubclass(data_type, Table) else
         "volume statistics" if issubclass(data_type, VolumeStatistics) else data_type.__name__)
