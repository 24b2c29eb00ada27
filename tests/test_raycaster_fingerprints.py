"""Every ray caster gives bit-identical outputs to those recorded before its rebuild on shared
components (tests/helpers/raycaster_cases.py and more_raycaster_cases.py list the configurations). Bits depend on the GL
driver, so the comparison runs where the recording was made (Mesa llvmpipe here) and is skipped,
saying so, elsewhere; record again with `cd tests && python -m helpers.raycaster_cases` after a deliberate change."""

import json

import pytest

from helpers.paths import REPO
from helpers.raycaster_cases import all_cases, fingerprint

RECORDED = json.loads((REPO / "tests" / "data" / "raycaster_fingerprints.json").read_text())
CASES = list(all_cases())


@pytest.fixture(scope="module")
def same_driver(gl):
    found = (gl.info["GL_RENDERER"], gl.info["GL_VERSION"])
    if found != (RECORDED["renderer"], RECORDED["version"]):
        pytest.skip(f"fingerprints were recorded on {RECORDED['renderer']} {RECORDED['version']}, "
                    f"this is {found[0]} {found[1]}")


@pytest.fixture(scope="module")
def gl():
    from vgraph.gl_context import get_context
    return get_context()


def test_every_configuration_is_recorded():
    assert sorted(name for name, *_ in CASES) == sorted(RECORDED["fingerprints"])


@pytest.mark.parametrize("name, make, outports", CASES, ids=[name for name, *_ in CASES])
def test_outputs_are_bit_identical_to_the_recording(same_driver, name, make, outports):
    assert fingerprint(make(), outports) == RECORDED["fingerprints"][name]
