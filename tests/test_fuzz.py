"""Fuzzing: every volume reader, OME-Zarr stores, ImageSource and the network loader, given mutated
valid files (bit flips, truncations, header line edits, extreme numbers, edited JSON documents;
for stores also deleted, swapped and oversized chunks, links and FIFOs) and files of random
bytes, either succeeds or raises a VGraphError; never another exception.

The cases come from bench/fuzz_cases.py, driven here by hypothesis (a modest number of examples
per target, so the file runs in well under a minute); bench/fuzz.py runs the same cases for
minutes with time and memory limits per case.
"""

import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vgraph.io import SUPPORTED_EXTENSIONS, read_volume
from vgraph.errors import VGraphError
from fuzz_cases import TARGETS, make_case, run_case

EXAMPLES = {"dicom": 100, "networks": 500, "stores": 100}  # a store case builds a zarr store: ~80 ms
FUZZ_SETTINGS = dict(deadline=None, database=None, derandomize=False,
                     suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def fuzz(target: str, folder: Path) -> None:
    @settings(max_examples=EXAMPLES.get(target, 300), **FUZZ_SETTINGS)
    @given(rng=st.randoms(use_true_random=False))
    def case_loads_or_raises_a_vgraph_error(rng):
        run_case(make_case(target, rng), Path(tempfile.mkdtemp(dir=folder)))

    case_loads_or_raises_a_vgraph_error()


@pytest.mark.parametrize("target", [t for t in TARGETS if t != "networks"])
def test_readers_give_a_volume_or_a_vgraph_error(tmp_path, target):
    fuzz(target, tmp_path)


def test_network_loader_gives_a_network_or_a_vgraph_error(tmp_path):
    fuzz("networks", tmp_path)


@settings(max_examples=500, **FUZZ_SETTINGS)
@given(extension=st.sampled_from(SUPPORTED_EXTENSIONS), content=st.binary(max_size=600))
def test_random_bytes_under_every_extension(extension, content):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"random{extension}"
        path.write_bytes(content)
        try:
            read_volume(path, raw={"dims": (2, 2, 2), "dtype": "uint8"} if extension == ".raw" else None)
        except VGraphError:
            pass


def test_a_writer_path_that_is_not_encodable_is_a_network_file_error(tmp_path):
    """Found by the network fuzzing (UnicodeEncodeError from the write-path check); fixed in
    FilePathProperty (commit 93d1865)."""
    import vgraph
    path = tmp_path / "n.json"
    path.write_text('{"format": "vgraph-network", "version": 1, "processors": [{"id": "w", '
                    '"type": "VolumeWriter", "properties": {"path": "out\\ud800.nrrd"}}]}')
    with pytest.raises(vgraph.NetworkFileError):
        vgraph.load(path)
