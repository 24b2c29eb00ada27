"""Fuzz cases for the volume readers, ImageSource and the network loader: valid inputs built from
scratch (fuzz_seeds.py, plus DICOM series, PNG images and the shipped networks here), mutated by
bit flips, truncations, header line edits and numbers replaced by extremes.

    case = make_case("nrrd", random.Random(7))
    outcome = run_case(case, empty_folder)     # "ok" or the VGraphError subclass's name

``run_case`` lets any other exception through: the contract of every reader and of the loader
is a complete result or a VGraphError. tests/test_fuzz.py drives this with hypothesis,
bench/fuzz.py for minutes with time and memory limits.
"""

from __future__ import annotations

import copy
import gzip
import io
import json
import os
import re
import struct
import warnings
from pathlib import Path

import numpy as np

from vgraph.errors import VGraphError
import fuzz_meshes
import fuzz_seeds
import fuzz_stores
from fuzz_seeds import Case, volume_values

NETWORKS = Path(__file__).resolve().parents[1] / "networks"
TEXT_EXTREMES = ("0", "-1", "1e30", "-1e30", "nan", "inf", "-inf", "1e400", "2147483648",
                 "4294967296", "-2147483649", "99999999999999999999999", "1e-320", "0x10", "",
                 "1.5", "9" * 5000, "\xff\xfe", "\u0661\u0662", "%.1000000000d", "LIST", "/dev/zero",
                 ".", "none")
JSON_EXTREMES = (None, True, False, 0, -1, 1e308, -1e308, float("nan"), float("inf"),
                 float("-inf"), 10**30, -(10**30), 2**63, 1e-320, "", "x" * 10000, [], {},
                 [[[]]], "../../../../etc/passwd", "/dev/zero", "\u0000", "\ud800", "1", [1, 2, 3],
                 # what a name must be before the system sees it, and values nested past the limit
                 "x" * 5000, "d" * 300 + ".png", "/".join(["d" * 200] * 21) + ".nrrd", "a\ud800b.png",
                 "\udce9.nrrd", "~nosuchuser_vgraph/x.png", ".", "x.json", "..", "sub/", "networks",
                 json.loads("[" * 65 + "]" * 65), json.loads('{"a":' * 65 + "1" + "}" * 65))
_PACKED_EXTREMES = (struct.pack("<i", -1), struct.pack("<i", 2**31 - 1), struct.pack("<h", -1),
                    struct.pack("<h", 32767), struct.pack("<f", float("nan")),
                    struct.pack("<f", float("inf")), struct.pack("<f", 1e30),
                    struct.pack("<d", 1e300), struct.pack("<q", 2**62), b"\x00" * 4, b"\xff" * 8)
_NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")
_FIELDS = {  # field names worth inserting into each text header
    "qvis": ("ObjectFileName", "Resolution", "SliceThickness", "Format", "ObjectModel", "Endianness"),
    "nrrd": ("sizes", "type", "encoding", "endian", "byte skip", "line skip", "data file",
             "dimension", "spacings", "space directions", "space origin", "min", "max"),
    "metaimage": ("NDims", "DimSize", "ElementType", "ElementSpacing", "HeaderSize",
                  "CompressedData", "ElementNumberOfChannels", "ElementDataFile", "ElementMin"),
    "slc": (), "vti": ()}
_FIELDS["nhdr"] = _FIELDS["nrrd"]


# --- seeds not in fuzz_seeds ---------------------------------------------------------------------
def dicom(rng) -> Case:
    """One to three slices of a series (+ sometimes a file that is not DICOM), opened as the
    folder or as one slice; fields sometimes set to odd values before writing."""
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import (DeflatedExplicitVRLittleEndian, ExplicitVRLittleEndian,
                             ImplicitVRLittleEndian)
    values = volume_values(rng, rng.choice(("uint8", "uint16", "int16")))
    syntax = rng.choice((ExplicitVRLittleEndian, ImplicitVRLittleEndian,
                         DeflatedExplicitVRLittleEndian))
    files = {}
    for k, plane in enumerate(values):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.4"
        meta.MediaStorageSOPInstanceUID = f"1.2.3.{rng.getrandbits(20)}.{k}"
        meta.TransferSyntaxUID = syntax
        ds = Dataset()
        ds.file_meta = meta
        ds.SOPClassUID, ds.SOPInstanceUID = meta.MediaStorageSOPClassUID, meta.MediaStorageSOPInstanceUID
        ds.SeriesInstanceUID, ds.InstanceNumber, ds.Modality = "1.2.3.4", k + 1, "MR"
        ds.Rows, ds.Columns = plane.shape
        ds.BitsAllocated = ds.BitsStored = plane.itemsize * 8
        ds.HighBit, ds.PixelRepresentation = ds.BitsStored - 1, int(plane.dtype.kind == "i")
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.PixelSpacing, ds.ImageOrientationPatient = [0.5, 0.75], [1, 0, 0, 0, 1, 0]
        ds.ImagePositionPatient = [0, 0, 2.5 * k]
        if rng.random() < 0.3:
            ds.RescaleSlope, ds.RescaleIntercept = rng.choice(("2", "1e35", "0.5")), "-1024"
        ds.PixelData = plane.tobytes()
        implicit = syntax == ImplicitVRLittleEndian
        valid = _dicom_bytes(ds, implicit)
        files[f"{k}.dcm"] = (_odd_dicom_field(rng, ds, implicit) or valid) if rng.random() < 0.3 \
            else valid
    if rng.random() < 0.2:
        files["notes.txt"] = b"not a DICOM file"
    return Case("dicom", files, rng.choice(("", "0.dcm")))


def _dicom_bytes(ds, implicit: bool) -> bytes:
    buffer = io.BytesIO()
    ds.save_as(buffer, implicit_vr=implicit, little_endian=True, enforce_file_format=True)
    return buffer.getvalue()


def _odd_dicom_field(rng, ds, implicit: bool) -> bytes | None:
    """The slice with one field set to an odd value, or None when pydicom will not write it."""
    name = rng.choice(("Rows", "Columns", "BitsAllocated", "BitsStored", "PixelSpacing",
                       "ImagePositionPatient", "ImageOrientationPatient", "RescaleSlope",
                       "SliceThickness", "NumberOfFrames", "SamplesPerPixel", "InstanceNumber"))
    value = rng.choice((0, 65535, "abc", "1e400", "nan", "", [1], [1, 2, 3, 4, 5, 6, 7], "-5"))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            setattr(ds, name, value)
            return _dicom_bytes(ds, implicit)
    except Exception:  # pydicom refused to store or to write it
        return None


def image(rng) -> Case:
    from PIL import Image
    mode = rng.choice(("L", "RGB", "RGBA", "I;16"))
    size = (rng.randint(1, 6), rng.randint(1, 6))
    pixels = np.random.default_rng(rng.getrandbits(32)).integers(0, 255, (size[1], size[0], 4))
    picture = Image.fromarray(pixels.astype(np.uint8), "RGBA").convert(mode if mode != "I;16" else "L")
    buffer = io.BytesIO()
    picture.save(buffer, format=rng.choice(("PNG", "JPEG")) if mode in ("L", "RGB") else "PNG")
    return Case("image", {"v.png": buffer.getvalue()}, "v.png")


def network(rng) -> Case:
    """A shipped network (or a minimal one when the repository's networks/ is not there),
    changed as a document, then as text."""
    seeds = sorted(NETWORKS.glob("*.json")) if NETWORKS.is_dir() else []
    document = json.loads(rng.choice(seeds).read_text()) if seeds else {
        "format": "vgraph-network", "version": 1,
        "processors": [{"id": "src", "type": "FunctionSelector", "properties": {}}]}
    if rng.random() < 0.15:
        document = _as_version_0(document)
    deep = None
    for _ in range(rng.randint(0, 4)):
        deep = _mutate_document(rng, document) or deep
    text = json.dumps(document, indent=rng.choice((None, 2)))
    if deep:
        text = text.replace('"__DEEP__"', "[" * deep + "]" * deep, 1)
    return Case("networks", {"n.json": text.encode("utf-8", "surrogatepass")}, "n.json")


def _as_version_0(document: dict) -> dict:
    return {"format": document.get("format"), "version": 0,
            "nodes": {p.get("id"): {k: v for k, v in p.items() if k != "id"}
                      for p in document.get("processors", [])},
            "edges": [f"{c['from']} -> {c['to']}" for c in document.get("connections", [])]}


def _json_extreme(rng):
    """A copy: the same list planted twice could end up inside itself (and the constants changed)."""
    return copy.deepcopy(rng.choice(JSON_EXTREMES))


def _mutate_document(rng, document: dict) -> int | None:
    """One edit of the document in place; returns a nesting depth when it planted a deep list."""
    places = list(_places(document))
    container, key = rng.choice(places) if places else (document, "format")
    kind = rng.randrange(11)
    processors = document.get("processors")
    properties = [p["properties"] for p in (processors if isinstance(processors, list) else [])
                  if isinstance(p, dict) and isinstance(p.get("properties"), dict) and p["properties"]]
    if kind == 8 and properties:  # a property value of any type: each property checks its own
        container = rng.choice(properties)
        container[rng.choice(sorted(container))] = _json_extreme(rng)
        return None
    if kind == 9 and isinstance(processors, list):  # names that reach the system: paths, TF names
        writer = rng.choice(({"id": "w", "type": "ImageWriter"}, {"id": "vw", "type": "VolumeWriter"}))
        processors.append({**writer, "properties": {}})
        named = [p for p in properties if {"path", "transfer_function"} & set(p)]
        named.append(processors[-1]["properties"])
        container = rng.choice(named)
        name = rng.choice(sorted({"path", "transfer_function"} & set(container)) or ["path"])
        container[name] = rng.choice(("", ".", "..", "x.json", "sub/", "networks", "n.json", "n.json/x.png",
                                      "d" * 300 + ".png", "x" * 5000, "a\ud800.png", "a\u0000.png",
                                      "/".join(["d" * 200] * 21), "~nosuchuser_vgraph/x.nrrd",
                                      "../x.png", "out.nii.gz", "grayscale", "x" * 255 + ".png"))
        return None
    if kind == 10 and isinstance(processors, list):  # a version-1 property under both its names
        document["version"] = 1
        type_name, old, new, values = rng.choice((
            ("RayCaster", "gradient", "derivatives", ("sobel", "central")),
            ("CurvatureRaycaster", "level", "iso_level", (0.25, 0.5))))
        processors.append({"id": f"old_{old}", "type": type_name,
                           "properties": dict(zip(rng.sample((old, new), 2), values))})
        return None
    if kind == 0 and isinstance(container, dict) and key in container:
        del container[key]
    elif kind == 1:
        container[key] = _json_extreme(rng)
    elif kind == 2:
        document["version"] = rng.choice((0, 2, -1, "1", 1.0, True, None, 10**20, 1))
    elif kind == 3 and isinstance(container, dict):
        container[rng.choice(("unknown", "x", "id", "type", "bidirectional"))] = _json_extreme(rng)
    elif kind == 4 and isinstance(processors, list) and processors:
        processors.append(json.loads(json.dumps(rng.choice(processors))))  # a duplicate id
    elif kind == 5:
        container[key] = "__DEEP__"
        return rng.choice((10, 100, 1000, 100000))
    elif kind == 6 and isinstance(container[key], (int, float)) and not isinstance(container[key], bool):
        container[key] = rng.choice((1e308, -1e308, 10**30, -(10**30), 2**63, -0.0, 1e-320))
    elif kind == 7 and isinstance(container[key], str):
        container[key] = rng.choice(("", "a.b", "src.volume", "writer.nothing", "x" * 300,
                                     container[key] + "x", container[key].upper()))
    return None


def _places(node, depth: int = 0):
    """(container, key) of every value in the document."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        yield node, key
        if depth < 20:
            yield from _places(value, depth + 1)


SEEDS = {"qvis": fuzz_seeds.qvis, "raw": fuzz_seeds.raw, "nrrd": fuzz_seeds.nrrd,
         "nhdr": fuzz_seeds.nhdr, "metaimage": fuzz_seeds.metaimage, "nifti": fuzz_seeds.nifti,
         "vti": fuzz_seeds.vti, "slc": fuzz_seeds.slc, "npy": fuzz_seeds.npy,
         "npz": fuzz_seeds.npz, "dicom": dicom, "image": image, "networks": network}
SEEDS["mesh"] = fuzz_meshes.mesh
SEEDS["stores"] = fuzz_stores.store
TARGETS = tuple(SEEDS)


# --- mutations -----------------------------------------------------------------------------------
def make_case(target: str, rng) -> Case:
    """A seed of ``target``, mutated 0 to 3 times (or, now and then, replaced by random bytes)."""
    case = SEEDS[target](rng)
    if rng.random() < 0.05:
        case.files[case.entry if case.entry in case.files else next(iter(case.files))] = \
            rng.randbytes(rng.randrange(2000))
        return case
    rounds = rng.choice((0, 1, 1, 2, 3))
    if target in ("networks", "stores") and rng.random() < 0.7:
        rounds = 0  # mostly document edits (their seeds made them): byte edits only break the JSON
    for _ in range(rounds):
        _mutate_case(rng, case)
    return case


def _mutate_case(rng, case: Case) -> None:
    if case.raw is not None and rng.random() < 0.4:
        _mutate_description(rng, case.raw)
        return
    name = case.header if case.header and rng.random() < 0.6 else rng.choice(sorted(case.files))
    blob = case.files[name]
    inner = name in case.gzipped and rng.random() < 0.6
    if inner:  # edit the content, not the compressed bytes, which would only fail the CRC
        blob = gzip.decompress(blob)
    if name == case.header and rng.random() < 0.7:
        blob = _edit_text(rng, blob, case.target)
    else:
        blob = _edit_bytes(rng, blob)
    case.files[name] = gzip.compress(blob, mtime=0) if inner else blob
    if not inner:
        case.gzipped.discard(name)  # its compressed bytes were edited: no longer a valid member


def _mutate_description(rng, description: dict) -> None:
    key = rng.choice(("dims", "dtype", "endianness", "spacing", "origin", "offset", "colour"))
    choice = rng.random()
    if choice < 0.2:
        description.pop(key, None)
    elif choice < 0.6:
        description[key] = copy.deepcopy(rng.choice(JSON_EXTREMES + (
            (1, 1), (2, 2, -2), (1e30, 1, 1), (np.nan, 1, 1), "complex64", "bool", "V8")))
    else:
        description[key] = [rng.choice((0, -1, 10**12, 1.5, float("nan"))) for _ in range(3)]


def _edit_text(rng, blob: bytes, target: str) -> bytes:
    lines = blob.split(b"\n")
    kind = rng.randrange(6)
    if kind == 0:
        return _replace_number(rng, blob)
    index = rng.randrange(len(lines))
    if kind == 1:
        del lines[index]
    elif kind == 2:
        lines.insert(index, lines[rng.randrange(len(lines))])
    elif kind == 3 and _FIELDS.get(target):
        separator = " = " if target == "metaimage" else ": "
        lines.insert(index, (rng.choice(_FIELDS[target]) + separator
                             + rng.choice(TEXT_EXTREMES)).encode("utf-8", "surrogatepass"))
    elif kind == 4:
        key, sep, _ = lines[index].partition(b"=" if b"=" in lines[index] else b":")
        lines[index] = key + sep + b" " + rng.choice(TEXT_EXTREMES).encode("utf-8", "surrogatepass")
    else:
        lines[index] = rng.choice((lines[index].upper(), lines[index].lower(), lines[index] * 2))
    return b"\n".join(lines)


def _replace_number(rng, blob: bytes) -> bytes:
    matches = [m for _, m in zip(range(300), _NUMBER.finditer(blob))]
    if not matches:
        return blob
    match = rng.choice(matches)
    extreme = rng.choice(TEXT_EXTREMES).encode("utf-8", "surrogatepass")
    return blob[:match.start()] + extreme + blob[match.end():]


def _edit_bytes(rng, blob: bytes) -> bytes:
    data = bytearray(blob)
    kind = rng.randrange(6)
    if kind == 0 or not data:
        return bytes(data) + rng.randbytes(rng.randrange(1, 64))
    at = rng.randrange(len(data))
    if kind == 1:
        for _ in range(rng.randint(1, 8)):
            data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
    elif kind == 2:
        packed = rng.choice(_PACKED_EXTREMES)
        data[at:at + len(packed)] = packed
    elif kind == 3:
        del data[at:]
    elif kind == 4:
        del data[at:at + rng.randint(1, 64)]
    else:
        data[at:at] = data[at:at + rng.randint(1, 64)] * rng.randint(1, 4)
    return bytes(data)


# --- running -------------------------------------------------------------------------------------
def write_case(case: Case, folder: Path) -> Path:
    """Writes the files, links and FIFOs; returns the path to open."""
    for name, content in case.files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_bytes(content)
    for name, target in case.links.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        os.symlink(target, folder / name)
    for name in case.fifos:
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        os.mkfifo(folder / name)
    return folder / case.entry if case.entry else folder


def run_case(case: Case, folder: Path) -> str:
    """Opens the case written into the (empty) ``folder``: "ok", or the name of the VGraphError
    subclass raised. Other exceptions propagate: they are the failures being hunted."""
    path = write_case(case, folder)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # non-finite voxels, pixdim fixes, pydicom's complaints
        try:
            _open(case, path)
        except VGraphError as error:
            return type(error).__name__
    return "ok"


def _open(case: Case, path: Path):
    if case.target == "networks":
        import vgraph
        from vgraph.write_paths import check_writers
        network = vgraph.load(path)
        check_writers(network, str(path))  # what vgraph validate and run refuse before evaluating
        return network
    if case.target == "mesh":
        from vgraph.io.meshes import read_mesh
        return read_mesh(path)
    if case.target == "stores":
        return fuzz_stores.open_store(path)
    if case.target == "image":
        from vgraph.processors.image_source import read_image_file
        return read_image_file("image", path.name, path)
    from vgraph.io import read_volume
    return read_volume(path, raw=case.raw)
